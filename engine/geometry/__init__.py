"""Geometric kernels shared by the whole engine, one home for each job (pure numpy, scipy and
shapely; nothing here imports the rest of the engine).

* :mod:`.alpha` — grid thinning and 2-D alpha shapes (triangles, area, shapely geometry,
  bounds that follow the point spacing);
* :mod:`.normals` — PCA of k-nearest-neighbour neighbourhoods (normals, eigenvalues);
* :mod:`.planes` — an orthonormal frame (u, v) on a plane from its normal;
* :mod:`.polygon` — shoelace areas, Newell normals, face triangulation, polyhedron volume,
  plan area and perimeter;
* :mod:`.boxes` — the minimum-area oriented box about the z axis;
* :mod:`.transforms` — 4×4 frame maths (apply, model ↔ input frame with the offset,
  dataset ↔ dataset, rigidity).

Every length is in metres, every area in m², unless a function says otherwise.
"""
