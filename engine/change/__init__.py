"""Change detection between a building model and a newer scan (docs/method.md §5).

:func:`detect_changes` registers the scan to the model (given transform, then point-to-plane
ICP, then a fitness check: an unregistered scan gets no change claimed), classifies each
scan point existing/new, measures the coverage of each room face by the existing points
(2D alpha shapes), flags redundant faces and clusters new points into candidate new
elements, gives each wall, slab, door and window a status (installed, incomplete, not
installed, no data: :mod:`.elements`) and fits new walls (:mod:`.newwalls`).
:func:`write_change_outputs` writes the classified points (PLY), the coverage per surface and
the status per element (JSON), a summary, changes.ifc (and as_built.ifc: :mod:`.update`).
"""
from .detect import (EXISTING, NEW, OUTSIDE, UNCLASSIFIED, ChangeParams, ChangeResult, cluster_points,
                     detect_changes)
from .elements import (INCOMPLETE, INSTALLED, NO_DATA, NOT_INSTALLED, STATUSES, StatusParams, element_global_id,
                       element_status)
from .newwalls import WallFitParams, fit_new_walls
from .registration import (REGISTERED, UNREGISTERED, RegistrationParams, RegistrationResult, model_points,
                           register, registration_quality, transform_model)
from .report import write_change_outputs
from .update import as_built_model, changes_model, write_as_built_ifc, write_changes_ifc

__all__ = [
    "ChangeParams", "ChangeResult", "detect_changes", "cluster_points", "EXISTING", "NEW", "UNCLASSIFIED",
    "OUTSIDE", "StatusParams", "element_status", "element_global_id", "INSTALLED", "INCOMPLETE",
    "NOT_INSTALLED", "NO_DATA", "STATUSES", "WallFitParams", "fit_new_walls", "as_built_model",
    "changes_model", "write_changes_ifc", "write_as_built_ifc",
    "RegistrationParams", "RegistrationResult", "register", "transform_model", "model_points",
    "registration_quality", "REGISTERED", "UNREGISTERED",
    "write_change_outputs",
]
