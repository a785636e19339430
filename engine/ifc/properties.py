"""Property sets and quantity sets, created directly.

The entities are those ``ifcopenshell.api.pset``'s ``add_pset`` + ``edit_pset`` (and
``add_qto`` + ``edit_qto``) make for a new set on an object: an ``IfcPropertySet`` of
``IfcPropertySingleValue`` (an ``IfcElementQuantity`` of ``IfcQuantityLength`` / ``Area`` /
``Volume``) and the ``IfcRelDefinesByProperties`` that gives it to the object.
The api looks every set's name up in buildingSMART's templates, whose first use loads them
from a file (50 ms a convert, more than the hundred sets it then writes), and goes through its
generic machinery per call (0.9 ms a set); a model's sets are written here in a twentieth of
that. The value types follow the api's rules: a standard property (``Pset_*``) takes its
template's measure type — :data:`STANDARD_MEASURES` holds those this writer sets, any other
is looked up in the templates — and any other value takes the type of its Python value
(``str`` IfcLabel, ``bool`` IfcBoolean, ``int`` IfcInteger, ``float`` IfcReal; an IFC value
entity such as an ``IfcText`` stays as it is). A quantity is an area or a volume when its name
says so (as the ``Qto_*`` templates type the names written here), else a length.
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

from .common import safe_text

__all__ = ["STANDARD_MEASURES", "property_values", "quantity_values", "quantity_kind", "measure_type",
           "set_property", "PropertyWriter"]

STANDARD_MEASURES = {"IsExternal": "IfcBoolean"}
"""Measure type of each standard (``Pset_*Common``) property this writer sets, as the
buildingSMART templates give it (a test checks them against the templates)."""


def measure_type(schema: str, pset: str, name: str, value) -> str:
    """The IFC measure type of property ``name`` of set ``pset`` holding ``value``."""
    if pset.startswith("Pset_"):
        t = STANDARD_MEASURES.get(name)
        if t is None:
            import ifcopenshell.util.pset

            template = ifcopenshell.util.pset.get_template(schema).get_by_name(pset)
            for p in getattr(template, "HasPropertyTemplates", None) or ():
                if p.Name == name:
                    t = p.PrimaryMeasureType or "IfcLabel"
        if t is not None:
            return t
    if isinstance(value, str):
        return "IfcLabel"
    if isinstance(value, float):
        return "IfcReal"
    if isinstance(value, bool):
        return "IfcBoolean"
    if isinstance(value, int):
        return "IfcInteger"
    raise TypeError(f"property {pset}.{name}: no IFC type for a {type(value).__name__}")


_CAST = {"IfcBoolean": bool, "IfcInteger": int, "IfcReal": float, "IfcLabel": str, "IfcIdentifier": str,
         "IfcText": str, "IfcLengthMeasure": float, "IfcPositiveLengthMeasure": float}


def _nominal(f, pset: str, name: str, value):
    import ifcopenshell

    if isinstance(value, ifcopenshell.entity_instance):
        return value
    t = measure_type(f.schema_identifier, pset, name, value)
    return f.create_entity(t, _CAST.get(t, lambda v: v)(value))


def property_values(f, pset: str, props: Mapping) -> list:
    """``IfcPropertySingleValue`` entities of ``props`` (name → value, None left out) of set ``pset``."""
    return [f.createIfcPropertySingleValue(k, None, _nominal(f, pset, k, v), None)
            for k, v in props.items() if v is not None]


def set_property(f, pset_entity, name: str, value) -> None:
    """Give property ``name`` of the property set ``pset_entity`` the value ``value`` (added
    when the set has none of that name)."""
    nominal = _nominal(f, pset_entity.Name or "", name, value)
    for p in pset_entity.HasProperties or ():
        if p.Name == name and p.is_a("IfcPropertySingleValue"):
            p.NominalValue = nominal
            return
    pset_entity.HasProperties = list(pset_entity.HasProperties or ()) + [
        f.createIfcPropertySingleValue(name, None, nominal, None)]


def quantity_kind(name: str) -> str:
    """"Area", "Volume" or "Length": the ``IfcQuantity*`` of quantity ``name``."""
    low = name.lower()
    return "Area" if "area" in low else "Volume" if "volume" in low else "Length"


def quantity_values(f, props: Mapping) -> list:
    """``IfcQuantity*`` entities of ``props`` (name → float)."""
    out = []
    for k, v in props.items():
        kind = quantity_kind(k)
        out.append(f.create_entity(f"IfcQuantity{kind}", Name=k, **{f"{kind}Value": float(v)}))
    return out


class PropertyWriter:
    """The IFC writer's property and quantity sets (a mixin of ``engine.ifc.writer._Writer``:
    it reads ``f``, ``_key``, ``_gid``, ``_own``, ``_history`` and ``_rel``)."""

    def _pset(self, product, name, props):
        props = {k: v for k, v in props.items() if v is not None}
        if not props:
            return
        for k, v in list(props.items()):
            if isinstance(v, str):
                v = props[k] = safe_text(v)
                if len(v) > 255:
                    props[k] = self.f.createIfcText(v)
        self._define(product, "IfcPropertySet", name, HasProperties=property_values(self.f, name, props))

    def _define(self, product, ifc_class, name, **attributes):
        """A property or quantity set ``name`` of ``product`` and the IfcRelDefinesByProperties
        giving it (:mod:`engine.ifc.properties`)."""
        owner = self._key(product)
        d = self.f.create_entity(ifc_class, GlobalId=self._gid((owner, "pset", name)),
                                 OwnerHistory=self._history(), Name=name, **attributes)
        self._own(d, (owner, "pset", name))
        self._rel("IfcRelDefinesByProperties", (owner, "defines", name), RelatedObjects=[product],
                  RelatingPropertyDefinition=d)
        return d

    def _qto(self, product, name, props):
        props = {k: float(v) for k, v in props.items() if v is not None and np.isfinite(v)}
        if props:
            self._define(product, "IfcElementQuantity", name, Quantities=quantity_values(self.f, props),
                         MethodOfMeasurement="BaseQuantities" if name.endswith("BaseQuantities") else None)

    def _pset_update(self, product, name, props):
        for rel in getattr(product, "IsDefinedBy", ()) or ():
            pd = rel.RelatingPropertyDefinition
            if rel.is_a("IfcRelDefinesByProperties") and pd.is_a("IfcPropertySet") and pd.Name == name:
                for k, v in props.items():
                    set_property(self.f, pd, k, v)
                return
