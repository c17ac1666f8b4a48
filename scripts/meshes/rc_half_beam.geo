// Half of the Saatci & Vecchio beam (2450 × 250 × 410 mm, mid-span at x = 0) in unstructured
// tetrahedra, for the mesh study of scripts/rc_beam_impact.rhai (--set mesh=gmsh): inclined
// faces in every direction instead of the structured cells' one family of diagonals.
// fdem check --mesh scripts/meshes/rc_half_beam.geo    (needs gmsh)
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 2.45, 0.25, 0.41};
// This line fixes the size at 50 mm and wins over fdem's size (gmsh's -clmax): with
// mesh=gmsh, --set cell=… has no effect. Kept so that the mesh is the one of the run on
// docs/applications/rc_beam_impact.md (9 771 tets); remove it to vary the size.
Mesh.CharacteristicLengthMax = 0.05;
Mesh.Algorithm3D = 10;          // HXT, then optimised: no slivers that cut the time step
Mesh.OptimizeThreshold = 0.5;
Physical Volume("beam") = {1};
