// The jointed band of scripts/notched_beam.rhai (mesh=gmsh), meshed unstructured by gmsh:
// x ∈ [-w, w] (w = 2 × size), y ∈ [0, 0.05], z ∈ [0, 0.2], with the 100 mm notch as a
// zero-width surface x = 0, z < 0.1 embedded in the volume (its faces get no joints). The two
// faces x = ±w are meshed structured (size × size squares cut along the diagonal the
// structured box generator uses) so that they match the continuous outer parts vertex for
// vertex; inside, the tetrahedra are unstructured (Delaunay). The size comes from the script:
// gmsh("meshes/notched_beam_band.geo", #{ size }) → -clmax → Mesh.MeshSizeMax.
h = Mesh.MeshSizeMax;
b = 0.05; H = 0.2; a = 0.1;
w = 2 * h;
ny = Round(b / h); nz = Round(H / h);
// Corners: x = -w (1-4), x = +w (5-8); notch points at x = 0 (9-12).
Point(1) = {-w, 0, 0, h}; Point(2) = {-w, b, 0, h}; Point(3) = {-w, b, H, h}; Point(4) = {-w, 0, H, h};
Point(5) = {w, 0, 0, h};  Point(6) = {w, b, 0, h};  Point(7) = {w, b, H, h};  Point(8) = {w, 0, H, h};
Point(9) = {0, 0, 0, h};  Point(10) = {0, b, 0, h}; Point(11) = {0, b, a, h}; Point(12) = {0, 0, a, h};
// Face x = -w and x = +w.
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Line(5) = {5, 6}; Line(6) = {6, 7}; Line(7) = {7, 8}; Line(8) = {8, 5};
// Edges along x (bottom ones split at the notch).
Line(9) = {1, 9}; Line(10) = {9, 5}; Line(11) = {2, 10}; Line(12) = {10, 6};
Line(13) = {4, 8}; Line(14) = {3, 7};
// The notch: bottom edge, tip, and its two side edges.
Line(15) = {9, 10}; Line(16) = {10, 11}; Line(17) = {11, 12}; Line(18) = {12, 9};
Curve Loop(1) = {1, 2, 3, 4};            Plane Surface(1) = {1};        // x = -w
Curve Loop(2) = {5, 6, 7, 8};            Plane Surface(2) = {2};        // x = +w
Curve Loop(3) = {9, 10, 5, -12, -11, -1}; Plane Surface(3) = {3};       // bottom z = 0
Curve Loop(4) = {13, -7, -14, 3};        Plane Surface(4) = {4};        // top z = H
Curve Loop(5) = {9, 10, -8, -13, 4};     Plane Surface(5) = {5};        // front y = 0
Curve Loop(6) = {11, 12, 6, -14, -2};    Plane Surface(6) = {6};        // back y = b
Curve Loop(7) = {15, 16, 17, 18};        Plane Surface(7) = {7};        // notch x = 0, z < a
Curve{15} In Surface{3};
Curve{18} In Surface{5};
Curve{16} In Surface{6};
Surface Loop(1) = {1, 2, 3, 4, 5, 6};
Volume(1) = {1};
Surface{7} In Volume{1};
// Structured faces x = ±w matching the box generator's cells.
Transfinite Curve{1, 3, 5, 7} = ny + 1;
Transfinite Curve{2, 4, 6, 8} = nz + 1;
Transfinite Surface{1} = {1, 2, 3, 4} Right;
Transfinite Surface{2} = {5, 6, 7, 8} Right;
Mesh.Algorithm3D = 1;         // Delaunay
Mesh.OptimizeThreshold = 0.5; // no slivers that cut the time step (docs/meshing.md)
