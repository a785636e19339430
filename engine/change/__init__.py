"""Change detection between a building model and a newer scan (docs/method.md §5).

:func:`detect_changes` registers the scan to the model (given transform, then point-to-plane
ICP, then a fitness check: an unregistered scan gets no change claimed), classifies each
scan point existing/new, measures the coverage of each room face by the existing points
(2D alpha shapes), flags redundant faces and clusters new points into candidate new
elements. :func:`write_change_outputs` writes the classified points (PLY), the
coverage per surface (JSON) and a summary.
"""
from .detect import EXISTING, NEW, UNCLASSIFIED, ChangeParams, ChangeResult, cluster_points, detect_changes
from .registration import (REGISTERED, UNREGISTERED, RegistrationParams, RegistrationResult, model_points,
                           register, registration_quality, transform_model)
from .report import write_change_outputs

__all__ = [
    "ChangeParams", "ChangeResult", "detect_changes", "cluster_points", "EXISTING", "NEW", "UNCLASSIFIED",
    "RegistrationParams", "RegistrationResult", "register", "transform_model", "model_points",
    "registration_quality", "REGISTERED", "UNREGISTERED",
    "write_change_outputs",
]
