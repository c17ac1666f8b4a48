// A unit box with a spherical hole of radius 0.25 at its centre (OpenCASCADE kernel).
// fdem check --mesh scripts/meshes/box_hole.geo    (needs gmsh)
// In a script: let mesh = gmsh("meshes/box_hole.geo", #{ size: 0.1 });
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 1, 1, 1};
Sphere(2) = {0.5, 0.5, 0.5, 0.25};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
Physical Volume("solid") = {3};
Physical Surface("outer") = {1, 2, 3, 4, 5, 6};
Physical Surface("hole") = {7};
