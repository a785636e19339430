"""Shape grammars of indoor reconstruction.

* Manhattan grammar (docs/method.md §2): :func:`reconstruct_manhattan` (scan → model) and
  :func:`reconstruct_grammar` (the grammar core on an aligned cloud).
* Generic grammar (docs/method.md §3): :func:`reconstruct_generic` — cells from the wall planes,
  the rjMCMC search for the interior spaces (:mod:`.rjmcmc`), walls and exterior.
* Shared rule code for every grammar (also the generic/rjMCMC one): the point-on-face
  index (:mod:`.ipof`), the rules classify / adjacency / connectivity / merge /
  containment (:mod:`.rules`), unions and shared faces (:mod:`.geometry`).
"""
from .generic import generic_model, reconstruct_generic, storey_cells
from .geometry import SharedFace, box_of, shared_faces, union_of_boxes
from .ipof import face_index, grid_face_index
from .manhattan import manhattan_model, place_storey, reconstruct_grammar, reconstruct_manhattan
from .params import (CellParams, CoverageParams, GenericParams, ManhattanParams, RjmcmcParams, estimate_noise,
                     estimate_spacing, params_from_data)
from .rjmcmc import search_spaces
from .rules import (DEFAULT_TAU, classify, derive_topology, is_part, merge, part_relations,
                    space_relations, wall_with_openings)

__all__ = [
    "generic_model", "reconstruct_generic", "storey_cells", "GenericParams", "CellParams", "CoverageParams",
    "RjmcmcParams", "search_spaces",
    "manhattan_model", "reconstruct_manhattan", "reconstruct_grammar", "place_storey",
    "ManhattanParams", "params_from_data", "estimate_spacing", "estimate_noise",
    "face_index", "grid_face_index", "union_of_boxes", "shared_faces", "SharedFace", "box_of",
    "classify", "part_relations", "merge", "space_relations", "derive_topology", "is_part",
    "wall_with_openings", "DEFAULT_TAU",
]
