// The UCS prism of scripts/ucs.rhai (50 × 50 × 100 mm), meshed unstructured by gmsh.
// The element size comes from the script: gmsh("meshes/ucs_prism.geo", #{ size }) → -clmax.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.05, 0.05, 0.1};
Mesh.Algorithm3D = 10;        // HXT
Mesh.OptimizeThreshold = 0.5; // no slivers that cut the time step (docs/meshing.md)
