// The jointed band of scripts/notched_beam.rhai (mesh=gmsh_plane): as notched_beam_band.geo
// (x ∈ [-w, w], w = 2 × size, y ∈ [0, 0.05], z ∈ [0, 0.2], unstructured Delaunay tetrahedra
// inside, the faces x = ±w structured to match the continuous outer parts), but the whole mid
// plane x = 0 is a surface of the mesh: the notch (z < 0.1, faces without joints) and the
// ligament above it (z > 0.1), so that a crack can run straight up from the notch tip along
// tetrahedron faces, as it does in the structured band. The tetrahedra are still unstructured
// on either side. gmsh("meshes/notched_beam_band_plane.geo", #{ size }) → Mesh.MeshSizeMax.
h = Mesh.MeshSizeMax;
b = 0.05; H = 0.2; a = 0.1;
w = 2 * h;
ny = Round(b / h); nz = Round(H / h);
// Corners: x = -w (1-4), x = +w (5-8); the mid plane x = 0 (9-10 bottom, 11-12 notch tip,
// 13-14 top).
Point(1) = {-w, 0, 0, h}; Point(2) = {-w, b, 0, h}; Point(3) = {-w, b, H, h}; Point(4) = {-w, 0, H, h};
Point(5) = {w, 0, 0, h};  Point(6) = {w, b, 0, h};  Point(7) = {w, b, H, h};  Point(8) = {w, 0, H, h};
Point(9) = {0, 0, 0, h};  Point(10) = {0, b, 0, h}; Point(11) = {0, b, a, h}; Point(12) = {0, 0, a, h};
Point(13) = {0, 0, H, h}; Point(14) = {0, b, H, h};
// Faces x = -w and x = +w.
Line(1) = {1, 2}; Line(2) = {2, 3}; Line(3) = {3, 4}; Line(4) = {4, 1};
Line(5) = {5, 6}; Line(6) = {6, 7}; Line(7) = {7, 8}; Line(8) = {8, 5};
// Edges along x, split at x = 0.
Line(9) = {1, 9}; Line(10) = {9, 5}; Line(11) = {2, 10}; Line(12) = {10, 6};
Line(13) = {4, 13}; Line(19) = {13, 8}; Line(14) = {3, 14}; Line(20) = {14, 7};
// The mid plane: notch bottom edge, tip, side edges; ligament side edges and top edge.
Line(15) = {9, 10}; Line(16) = {10, 11}; Line(17) = {11, 12}; Line(18) = {12, 9};
Line(21) = {12, 13}; Line(22) = {13, 14}; Line(23) = {14, 11};
// The two halves x < 0 and x > 0 share the mid plane.
Curve Loop(1) = {1, 2, 3, 4};              Plane Surface(1) = {1};   // x = -w
Curve Loop(2) = {5, 6, 7, 8};              Plane Surface(2) = {2};   // x = +w
Curve Loop(3) = {9, 15, -11, -1};          Plane Surface(3) = {3};   // bottom, x < 0
Curve Loop(4) = {10, 5, -12, -15};         Plane Surface(4) = {4};   // bottom, x > 0
Curve Loop(5) = {13, 22, -14, 3};          Plane Surface(5) = {5};   // top, x < 0
Curve Loop(6) = {19, -7, -20, -22};        Plane Surface(6) = {6};   // top, x > 0
Curve Loop(7) = {9, -18, 21, -13, 4};      Plane Surface(7) = {7};   // front y = 0, x < 0
Curve Loop(8) = {10, -8, -19, -21, 18};    Plane Surface(8) = {8};   // front y = 0, x > 0
Curve Loop(9) = {11, 16, -23, -14, -2};    Plane Surface(9) = {9};   // back y = b, x < 0
Curve Loop(10) = {12, 6, -20, 23, -16};    Plane Surface(10) = {10}; // back y = b, x > 0
Curve Loop(11) = {15, 16, 17, 18};         Plane Surface(11) = {11}; // notch x = 0, z < a
Curve Loop(12) = {-17, -23, -22, -21};     Plane Surface(12) = {12}; // ligament x = 0, z > a
Surface Loop(1) = {1, 3, 5, 7, 9, 11, 12};
Volume(1) = {1};
Surface Loop(2) = {2, 4, 6, 8, 10, 11, 12};
Volume(2) = {2};
// Structured faces x = ±w matching the box generator's cells.
Transfinite Curve{1, 3, 5, 7} = ny + 1;
Transfinite Curve{2, 4, 6, 8} = nz + 1;
Transfinite Surface{1} = {1, 2, 3, 4} Right;
Transfinite Surface{2} = {5, 6, 7, 8} Right;
Mesh.Algorithm3D = 1;         // Delaunay
Mesh.OptimizeThreshold = 0.5; // no slivers that cut the time step (docs/meshing.md)
