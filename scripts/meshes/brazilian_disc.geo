// The Brazilian disc of scripts/brazilian_disc.rhai (--set mesh=gmsh) in unstructured
// tetrahedra: D = 100 mm, thickness 20 mm, axis along y, centred at the origin, loaded along
// z. The poles (0, ±R) are points of the geometry, so a mesh vertex lies on each and the
// platens touch there; nothing else is aligned with the loaded diameter (x = 0), unlike the
// structured O-grid of disc(..), whose grid lines run along it.
// fdem check --mesh scripts/meshes/brazilian_disc.geo    (needs gmsh)
R = 0.05;
T = 0.02;
Point(1) = {0, -T/2, 0};
Point(2) = {R, -T/2, 0};
Point(3) = {0, -T/2, R};
Point(4) = {-R, -T/2, 0};
Point(5) = {0, -T/2, -R};
Circle(1) = {2, 1, 3};
Circle(2) = {3, 1, 4};
Circle(3) = {4, 1, 5};
Circle(4) = {5, 1, 2};
Curve Loop(1) = {1, 2, 3, 4};
Plane Surface(1) = {1};
out[] = Extrude {0, T, 0} { Surface{1}; };
// Element size: fdem run --set size=… (gmsh -clmax); a size set here would override it.
Mesh.Algorithm3D = 10;          // HXT, then optimised: no slivers that cut the time step
Mesh.OptimizeThreshold = 0.5;
Physical Volume("disc") = {out[1]};
