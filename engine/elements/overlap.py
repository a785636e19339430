"""Openings measured on one wall that overlap in its plane (:mod:`.openings`): neighbours
measured from the mullion or transom between them are trimmed to meet halfway; rival readings
of one hole as a door and, first, as a window (a closed door's leaf behind one face, and a band
between a mobile scanner's lines across it) keep the door when it is the better supported."""
from __future__ import annotations

__all__ = ["abut", "admit", "overlap", "overlaps"]


def overlaps(a: dict, b: dict) -> tuple[float, float]:
    """How far two measured openings overlap along the wall and in height, metres (≤ 0: not)."""
    return (min(a["u1"], b["u1"]) - max(a["u0"], b["u0"]),
            min(a["sill"] + a["height"], b["sill"] + b["height"]) - max(a["sill"], b["sill"]))


def _gaps(a: dict, b: dict, gap: float, share: float) -> tuple[float, float]:
    """The overlap along the wall and in height up to which two openings are neighbours:
    ``gap``, or ``share`` of the narrower's width (the lower's height) when that is more."""
    return (max(gap, share * min(a["width"], b["width"])), max(gap, share * min(a["height"], b["height"])))


def _side_by_side(ou: float, oz: float, gu: float, gz: float) -> bool:
    return ou <= gu and oz > gz


def _stacked(ou: float, oz: float, gu: float, gz: float) -> bool:
    return oz <= gz and ou > gu


def overlap(a: dict, b: dict, gap: float = 0.0, share: float = 0.0) -> bool:
    """Whether two measured openings overlap in the wall's plane by more than ``gap``
    (metres; or ``share`` of the narrower one's width, of the lower one's height) across one
    edge only (two windows measured from the mullion or transom between them overlap by
    less: they are neighbours, see :func:`abut`)."""
    ou, oz = overlaps(a, b)
    gu, gz = _gaps(a, b, gap, share)
    return ou > 0 and oz > 0 and not (_side_by_side(ou, oz, gu, gz) or _stacked(ou, oz, gu, gz))


def abut(a: dict, b: dict, gap: float, share: float = 0.0) -> None:
    """Two neighbouring openings overlapping by at most ``gap`` (or ``share``, as in
    :func:`overlap`) across one edge trimmed (in place) to meet halfway."""
    ou, oz = overlaps(a, b)
    if ou <= 0 or oz <= 0:
        return
    gu, gz = _gaps(a, b, gap, share)
    if _side_by_side(ou, oz, gu, gz):  # side by side
        lo, hi = (a, b) if a["u0"] + a["u1"] <= b["u0"] + b["u1"] else (b, a)
        lo["u1"] = hi["u0"] = (lo["u1"] + hi["u0"]) / 2
        for o in (lo, hi):
            o["width"] = o["u1"] - o["u0"]
    elif _stacked(ou, oz, gu, gz):  # one above the other
        lo, hi = (a, b) if a["sill"] <= b["sill"] else (b, a)
        top = hi["sill"] + hi["height"]
        lo["height"] = (hi["sill"] - lo["sill"] + lo["height"]) / 2
        hi["sill"] = lo["sill"] + lo["height"]
        hi["height"] = top - hi["sill"]


def admit(found: list, o, gap: float, share: float = 0.0) -> list:
    """``found`` with the measured opening ``o`` (None: nothing) added when it overlaps none
    of them (:func:`overlap` by more than ``gap`` or ``share``), or, being a door, only windows less
    supported than it (``confidence``), which it then replaces; its neighbours are trimmed to
    meet it (:func:`abut`). Of two readings of one kind the first stays (gaps on both faces are
    read first: a gap on one face beside an open door is its leaf's or a shadow's), and a
    window never replaces a door: a door's hole reaches the floor, and a window read within it
    is its glazing or a band between a scanner's lines."""
    if o is None or o["width"] <= 0:
        return found
    clash = [f for f in found if overlap(o, f, gap, share)]
    if clash and (o["kind"] != "door" or any(f["kind"] != "window" or o["confidence"] <= f["confidence"]
                                               for f in clash)):
        return found
    kept = [f for f in found if not any(f is g for g in clash)]
    for f in kept:
        abut(o, f, gap, share)
    return kept + [o]
