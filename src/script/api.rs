//! The script API as data: every function, its parameters, units and defaults. `fdem doc`
//! prints it, `docs/script-reference.md` is generated from it (a test keeps them equal), and
//! option maps are validated against it, so an allowed key is always a documented key. Laws
//! declare their parameters beside themselves in the core ([`crate::params`]); this table
//! points to them.

use crate::params::{LawParams, Param};

/// One key of an options map: a [`Param`] (laws declare theirs beside themselves; the keys
/// of other functions are declared here).
pub type Key = Param;

/// One script function.
#[derive(Clone, Copy, Debug)]
pub struct FnDoc {
    /// Name as called (`sim.run` for methods).
    pub name: &'static str,
    pub signature: &'static str,
    pub summary: &'static str,
    pub keys: &'static [Key],
    /// For functions whose first argument names a law (`joint_law("tied", …)`): the laws
    /// and their own keys, which are allowed besides `keys`.
    pub laws: &'static [LawParams],
    /// API section.
    pub section: &'static str,
}

const fn key(
    name: &'static str,
    kind: &'static str,
    unit: &'static str,
    default: &'static str,
    doc: &'static str,
) -> Key {
    Param::other(name, kind, unit, default, doc)
}

pub const SECTIONS: &[(&str, &str)] = &[
    ("Parameters and checks", "Script parameters overridable with `--set`, self-checks, and numbers formatted for printing."),
    ("Simulation", "The model: create it, set integration options, run it in stages."),
    ("Materials", "Elastic laws of the tetrahedra (stage 1). Equations in docs/theory/elements.md."),
    ("Geometry and meshes", "Shapes (also used as selection regions), meshing, transformations."),
    ("Generators", "Meshes of solids with curved faces and of test specimens, and masonry assemblies (one mesh per block). Every generated mesh carries named face, node and element sets; measured quality and volume errors are in docs/generators.md."),
    ("Bodies and selections", "Bodies are meshes placed in the simulation; selections are node, face and element sets. A body or a selection belongs to the simulation that made it: giving it to another simulation's function is an error naming both."),
    ("Joints and fracture", "Stages 2–3: cohesive joints between the tetrahedra of jointed bodies; joints break, bodies fragment. Equations in docs/theory/joints.md."),
    ("Contact", "Stages 4–5: surface elements (outer faces and broken joints) touch, slide and collide through Munjiza's potential contact force with Coulomb friction. Equations in docs/theory/contact.md."),
    ("Reinforcement", "Rebars: 2-node bar elements of elastic–plastic steel (stage 1) embedded in a host body through bond points with a bond–slip law (stage 2); they bridge the host's cracks. Equations in docs/theory/reinforcement.md."),
    ("Loads and constraints", "Stage 6: gravity, forces, tractions, fixed and prescribed-velocity nodes, initial velocity."),
    ("Earthquake records", "Ground-motion records: read, process, and measure them (PGA, PGV, Arias intensity, response spectrum). Equations in docs/theory/ground_motion.md."),
    ("Hooks, monitors and output", "Periodic callbacks, monitored quantities (CSV), plots (PNG, SVG), ParaView frames."),
    ("Queries", "Read the state from a script or a callback (`s` is the simulation)."),
];

pub const GROUND_MOTION_KEYS: &[Key] = &[
    key("format", "string", "", "by extension", "\"at2\", \"two_column\" (or \"csv\"), \"one_column\". Default: `.AT2` files are at2, others two-column, or one-column when `dt` is given."),
    key("units", "string", "", "\"g\"", "Acceleration unit of the file: \"g\" (9.80665 m/s²), \"m/s2\" or \"cm/s2\"."),
    key("dt", "float", "s", "-", "Time step of a one-column file."),
    key("scale", "float", "-", "1", "Multiply the acceleration by this factor (not with `pga`)."),
    key("pga", "float", "file's units", "-", "Scale the record to this peak |a|, in the file's `units` (e.g. 0.13 with \"g\"). Not with `scale`."),
    key("start", "float", "s", "0", "Keep samples from this time on; the kept part starts again at t = 0."),
    key("end", "float", "s", "end of record", "Keep samples up to this time."),
    key("baseline", "bool", "", "false", "Remove c₀ + c₁·t/T from the acceleration so that the final velocity and displacement are zero (no drift after the record)."),
];

pub const SHAKE_KEYS: &[Key] = &[
    key("x", "GroundMotion", "", "-", "Record of the ground acceleration along x (from `ground_motion(..)`)."),
    key("y", "GroundMotion", "", "-", "Record along y."),
    key("z", "GroundMotion", "", "-", "Record along z (vertical). At least one of x, y, z."),
    key("start", "float", "s", "now", "Simulation time at which the records' t = 0 falls; not before the current time. Before it and after each record the ground acceleration is zero."),
];

pub const REBAR_KEYS: &[Key] = &[
    key("points", "array of [x, y, z]", "m", "required", "The bar's polyline; a closed stirrup repeats its first point at the end. Every point must lie inside the host."),
    key("diameter", "float", "m", "required", "Bar diameter d: bond perimeter πd, section πd²/4 unless `area` is given."),
    key("area", "float", "m²", "πd²/4", "Nominal section A₀ (e.g. 700e-6 for a No. 30 bar)."),
    key("steel", "Steel", "", "required", "From `steel(..)`."),
    key("bond", "BondLaw", "", "required", "From `bond_law(..)`."),
    key("segment", "float", "m", "1.2 × the host's mean element size", "Largest bar element length; each leg of the polyline is split into equal bars no longer than this."),
    key("bending", "bool", "", "true", "Bending at the bar nodes (dowel action across a sliding crack): a hinge where two bars meet, moment M = EI·θ/L̄ on the turning angle θ (I = πd⁴/64, L̄ the mean bar length), elastic–perfectly plastic at M_p = f_y·d³/6. `false`: a chain of pins, axial force only."),
    key("name", "string", "", "\"rebar<N>\"", "Name used in messages."),
];

pub const STRAIGHT_BAR_KEYS: &[Key] = &[
    key("axis", "string", "", "required", "\"x\", \"y\" or \"z\": the bar's direction."),
    key("at", "[a, b]", "m", "required", "The bar's other two coordinates, in axis order (y, z for \"x\"; z, x for \"y\"; x, y for \"z\")."),
    key("cover", "float", "m", "0", "End cover: the bar stops this far short of the host's ends."),
];

pub const STIRRUP_KEYS: &[Key] = &[
    key(
        "axis",
        "string",
        "",
        "required",
        "\"x\", \"y\" or \"z\": the member's axis (the stirrup lies in the section normal to it).",
    ),
    key(
        "at",
        "float",
        "m",
        "required",
        "Coordinate of the section along the axis.",
    ),
    key(
        "cover",
        "float",
        "m",
        "0",
        "Cover to the stirrup's outer surface.",
    ),
    key(
        "diameter",
        "float",
        "m",
        "0",
        "Stirrup diameter: the centreline lies cover + d/2 inside the host's bounds.",
    ),
];

pub const SIMULATION_KEYS: &[Key] = &[
    key("name", "string", "", "script file stem", "Name used in output file names: letters, digits, `_`, `-` (no `/`, `\\`, leading `.`, at most 100 characters)."),
    key("out_dir", "string", "", "\"out/<name>\"", "Output directory (created when first written). `fdem run --out DIR` overrides it. One directory per simulation: a second simulation of the script whose directory is taken writes to `<dir>/<name>/` (a line says so). Output of an earlier run there (frames, energy.csv, cracks.csv, monitor CSVs) is an error unless `fdem run --overwrite`, which removes it first."),
    key("energy_every", "int", "steps", "50", "Sample the energy account every this many steps, and on the last step of every run (appended to energy.csv as sampled). Inverted elements and non-finite values are detected on every step, whatever this is."),
    key("stress_output", "string", "", "\"cauchy\"", "Extra stress field written to VTK besides the Cauchy stress: \"cauchy\", \"pk1\" or \"pk2\"."),
    key("vtk_encoding", "string", "", "\"raw\"", "Appended data of `.vtu` files: \"raw\" (fast; ParaView, VTK, meshio) or \"base64\" (for readers without raw support, e.g. vtkio)."),
    key("vtk_pieces", "string", "", "\"one\"", "Frames as one `.vtu` each, written by rank 0 (\"one\"), or in pieces (\"per_rank\"): each rank writes the tets whose first node it owns as `NAME_NNNNNN_pR.vtu` (with `tet_id` and `node_id` arrays), rank 0 a `NAME_NNNNNN.pvtu` naming them, which the `.pvd` lists and ParaView opens as one model (docs/cluster.md). One piece on a single process."),
];

pub const BOX_KEYS: &[Key] = &[
    key("min", "vec3", "m", "required", "Lower corner."),
    key("max", "vec3", "m", "required", "Upper corner."),
];
pub const SPHERE_KEYS: &[Key] = &[
    key("center", "vec3", "m", "required", "Centre."),
    key("radius", "float", "m", "required", "Radius."),
];
pub const CYLINDER_KEYS: &[Key] = &[
    key("base", "vec3", "m", "required", "Centre of the base disc."),
    key(
        "axis",
        "vec3",
        "-",
        "required",
        "Axis direction (normalised).",
    ),
    key("radius", "float", "m", "required", "Radius."),
    key(
        "length",
        "float",
        "m",
        "required",
        "Length along the axis from `base`.",
    ),
];
pub const HALF_SPACE_KEYS: &[Key] = &[
    key(
        "point",
        "vec3",
        "m",
        "required",
        "A point on the bounding plane.",
    ),
    key(
        "normal",
        "vec3",
        "-",
        "required",
        "The region is the side this normal points to: (x − point)·normal ≥ 0.",
    ),
];
pub const MESH_KEYS: &[Key] = &[
    key(
        "size",
        "float",
        "m",
        "required unless divisions",
        "Target edge length. Boxes: each side gets round(L/size) ≥ 1 cells, each cell 6 tetrahedra. Cylinders: default radius/5; spheres: default radius/8.",
    ),
    key(
        "divisions",
        "array of 3 ints",
        "",
        "-",
        "Cells along x, y, z instead of `size`.",
    ),
    key(
        "pattern",
        "string",
        "",
        "\"kuhn\"",
        "Boxes: how each cell is split into 6 tetrahedra. \"kuhn\": every cell alike, along its diagonal from the min to the max corner, so the inner faces lean one way and an inclined crack runs straight in one family of directions only (turned end for end, the same box has the other family). \"alternating\": cell (i, j, k) mirrored in each axis whose index is odd; inclined faces of both directions, and with even divisions the mesh is its own mirror image. For fracture along inclined planes (shear cracks, plugs) use \"alternating\" or an unstructured mesh.",
    ),
];
pub const DISC_KEYS: &[Key] = &[
    key("radius", "float", "m", "required", "Radius."),
    key(
        "thickness",
        "float",
        "m",
        "required",
        "Thickness along the axis.",
    ),
    key(
        "center",
        "vec3",
        "m",
        "[0, 0, 0]",
        "Centre of the disc (mid-thickness).",
    ),
    key("axis", "vec3", "-", "[0, 0, 1]", "Axis direction."),
    key(
        "size",
        "float",
        "m",
        "radius/5",
        "Target edge length (32 segments around the circle at the default).",
    ),
];
pub const HOLLOW_CYLINDER_KEYS: &[Key] = &[
    key("inner_radius", "float", "m", "required", "Inner radius."),
    key(
        "outer_radius",
        "float",
        "m",
        "required",
        "Outer radius (> inner_radius).",
    ),
    key(
        "length",
        "float",
        "m",
        "required",
        "Length along the axis from `base`.",
    ),
    key("base", "vec3", "m", "[0, 0, 0]", "Centre of the base."),
    key("axis", "vec3", "-", "[0, 0, 1]", "Axis direction."),
    key(
        "size",
        "float",
        "m",
        "min((outer − inner)/3, π(inner + outer)/32)",
        "Target edge length (at least 12 cells around).",
    ),
];
pub const NOTCHED_BEAM_KEYS: &[Key] = &[
    key("length", "float", "m", "required", "Length along x."),
    key("height", "float", "m", "required", "Height along z."),
    key("width", "float", "m", "required", "Width along y."),
    key("notch_depth", "float", "m", "required", "Depth of the mid-span notch from the bottom face, in (0, height)."),
    key("notch_width", "float", "m", "required", "Width of the notch along x, smaller than `span`."),
    key("span", "float", "m", "0.8 × length", "Distance between the supports (centred), at most `length`."),
    key("origin", "vec3", "m", "[0, 0, 0]", "Corner of the beam: it occupies origin + [0, length] × [0, width] × [0, height]."),
    key("size", "float", "m", "min(height/10, 2.5 × notch_width)", "Target edge length, at most 2.5 × notch_width (thinner notch cells would be slivers); cells shrink towards the notch down to half its width (growing ≤ 35 % per cell)."),
];
pub const ARCH_KEYS: &[Key] = &[
    key("radius", "float", "m", "required", "Intrados radius R."),
    key("thickness", "float", "m", "required", "Radial thickness t."),
    key("depth", "float", "m", "required", "Out-of-plane width (along y, centred on y = 0)."),
    key("voussoirs", "int", "", "required", "Number of voussoirs, ≥ 3."),
    key("span_angle", "float", "°", "180", "Angle subtended: 180 for a semicircular arch, less for a segmental one; in (0, 360)."),
    key("center", "vec3", "m", "[0, 0, 0]", "Centre of the intrados circle (the arch stands in the x–z plane, symmetric about the vertical through it)."),
    key("size", "float", "m", "thickness/3", "Target edge length."),
];
pub const WALL_KEYS: &[Key] = &[
    key("courses", "int", "", "required", "Number of courses (≥ 1), stacked along z."),
    key("bricks_per_course", "int", "", "required", "Full bricks in even courses (≥ 1); odd courses have a half brick at each end and one full brick fewer."),
    key("brick", "vec3", "m", "required", "Brick [length (x), height (z), width (y)]."),
    key("head_gap", "float", "m", "0", "Gap between bricks of a course; 0: coincident faces (for mortar joints with `between`)."),
    key("bed_gap", "float", "m", "0", "Gap between courses."),
    key("origin", "vec3", "m", "[0, 0, 0]", "Lower corner of the wall."),
    key("size", "float", "m", "min(brick)/2", "Target edge length."),
];
pub const DOME_KEYS: &[Key] = &[
    key("radius", "float", "m", "required", "Intrados radius R."),
    key("thickness", "float", "m", "required", "Radial thickness t."),
    key("courses", "int", "", "required", "Number of courses (≥ 1), equal steps of polar angle from `base` up to `oculus`."),
    key("blocks_per_course", "int", "", "required", "Blocks in every course, ≥ 3; odd courses are offset by half a block (running bond)."),
    key("oculus", "float", "°", "10", "Polar half-angle of the opening at the crown, in (0, base). A closed crown (keystone) is not generated."),
    key("base", "float", "°", "90", "Polar angle of the base (90: hemisphere), in (oculus, 180)."),
    key("center", "vec3", "m", "[0, 0, 0]", "Centre of the sphere; the pole is on +z."),
    key("size", "float", "m", "thickness/2", "Target edge length."),
];
pub const CLOISTER_VAULT_KEYS: &[Key] = &[
    key("span", "float", "m", "required", "Inner span across flats at the springing, 2a (a: apothem of the intrados octagon). Florence: about 45."),
    key("thickness", "float", "m", "required", "Shell thickness t, along the radius of the profile circle in the section that carries it (the extrados is the coaxial circle of radius r + t there). With profile \"webs\" that is the web normal; with \"corners\" it is in the corner plane, and across the web the shell is t cos 22.5° at the springing, rising towards t as the web turns horizontal."),
    key("courses", "int", "", "required", "Number of courses (≥ 1): equal steps of the arc angle ψ from the springing (course 0, springers) to the top bed. Bed joints are planes through each web's cylinder axis."),
    key("blocks_per_web", "int", "", "required", "Blocks across each web per course (≥ 1); odd courses are offset by half a block, so a bent block straddles each corner. With ribs: web blocks between two ribs in even courses (odd: a half block at each end and one full block fewer)."),
    key("profile_ratio", "float", "-", "0.8", "Radius of the intrados profile circle over the span across corners D_c = span / cos 22.5°: r = profile_ratio · D_c, centre on the springing plane beyond the axis (see `profile`). 0.8 is the \"quinto acuto\". At least 1/2 with profile \"corners\", cos(22.5°)/2 ≈ 0.462 with \"webs\" (round crown)."),
    key("profile", "string", "", "\"corners\"", "Which vertical section carries the profile circle. \"corners\": the eight corner ribs (Florence as usually described), (q − q_c)² + z² = r² in each corner plane, q the distance from the axis, q_c = D_c/2 − r; the web mid-lines are that circle compressed horizontally by cos 22.5° (ellipses); crown D_c √(p − 1/4) above the springing (p = profile_ratio). \"webs\": each web's mid-line, (s − s_c)² + z² = r², s the distance from the axis, s_c = span/2 − r; the corner sections are ellipses; crown √(2r·span/2 − span²/4). Either way each web is a cylinder with a horizontal axis parallel to its side."),
    key("oculus", "float", "m", "span/8", "Inner opening across flats at the top: the webs end where the intrados mid-line is oculus/2 from the axis. In (0, span)."),
    key("ribs", "bool", "", "false", "A rib block at each corner in every course, straddling it (the running bond stops there), projecting beyond the web extrados; set `rib` on its free faces."),
    key("rib_width", "float", "m", "one block width", "Only with `ribs: true`. Rib width across the corner, along the intrados at the springing, in (0, span · tan 22.5°); rounded to an even number of mesh cells."),
    key("rib_depth", "float", "m", "thickness", "Only with `ribs: true`. How far a rib projects beyond the web extrados, measured as `thickness` is."),
    key("center", "vec3", "m", "[0, 0, 0]", "Centre of the springing octagon; the axis is vertical (+z), corner 0 of the octagon on +x."),
    key("size", "float", "m", "thickness/2", "Target edge length."),
];
pub const BICONCAVE_CELL_KEYS: &[Key] = &[
    key("radius", "float", "m", "3.91e-6", "Cell radius R₀ (Evans & Fung 1972, human red blood cell)."),
    key("c0", "float", "m", "0.81e-6", "Thickness coefficient C₀: D(r) = √(1 − ρ²)(C₀ + C₁ρ² + C₂ρ⁴), ρ = r/R₀."),
    key("c1", "float", "m", "7.83e-6", "Thickness coefficient C₁."),
    key("c2", "float", "m", "-4.39e-6", "Thickness coefficient C₂."),
    key("center", "vec3", "m", "[0, 0, 0]", "Centre of the cell (on its mid-plane)."),
    key("axis", "vec3", "-", "[0, 0, 1]", "Axis of symmetry."),
    key("size", "float", "m", "radius/3", "Target edge length across the diameter; there are as many layers through the thickness, so tets where the cell is thin are flat (about 10:1 at a red cell's centre)."),
];
pub const RANDOM_PACKING_KEYS: &[Key] = &[
    key("count", "int", "", "required", "Number of copies (≥ 1)."),
    key("min", "vec3", "m", "required", "Lower corner of the box every copy lies inside."),
    key("max", "vec3", "m", "required", "Upper corner of the box."),
    key("gap", "float", "m", "0", "Smallest distance between copies (conservative: two tets are apart only if some separating axis parts them by `gap`)."),
    key("rotate", "bool", "", "true", "Uniformly random orientations (uniform on SO(3)); false keeps the mesh's orientation."),
    key("seed", "int", "", "1", "Seed of the random stream: the same seed gives the same packing on any machine."),
    key("attempts", "int", "", "100 × count", "Draws allowed before giving up with an error saying how many copies fitted."),
];
pub const ADD_BLOCKS_KEYS: &[Key] = &[
    key(
        "layout",
        "string",
        "",
        "\"continuous\"",
        "Layout of every block, as in `sim.add_body`.",
    ),
    key(
        "prefix",
        "string",
        "",
        "\"block\"",
        "Bodies are named `<prefix>_0`, `<prefix>_1`, … in block order.",
    ),
];
pub const TET_MESH_KEYS: &[Key] = &[
    key(
        "nodes",
        "array of vec3",
        "m",
        "required",
        "Node coordinates.",
    ),
    key(
        "tets",
        "array of [int; 4]",
        "",
        "required",
        "Node ids of each tetrahedron, right-handed: (p1−p0)·((p2−p0)×(p3−p0)) > 0.",
    ),
];
pub const GMSH_KEYS: &[Key] = &[key(
    "size",
    "float",
    "m",
    "the .geo file's own sizes",
    "Largest element size (gmsh -clmax); .geo files only. Point sizes in the .geo file and gmsh's own defaults can make elements smaller.",
)];
pub const MIRROR_KEYS: &[Key] = &[
    key(
        "point",
        "vec3",
        "m",
        "required",
        "A point on the mirror plane.",
    ),
    key(
        "normal",
        "vec3",
        "-",
        "required",
        "Normal of the mirror plane (not zero).",
    ),
];
pub const ARRAY_KEYS: &[Key] = &[
    key(
        "count",
        "array of 3 ints",
        "",
        "required",
        "Copies along x, y, z (each ≥ 1).",
    ),
    key(
        "spacing",
        "vec3",
        "m",
        "required",
        "Offset between neighbouring copies along x, y, z.",
    ),
];
pub const ROTATE_KEYS: &[Key] = &[
    key(
        "axis",
        "vec3",
        "-",
        "required",
        "Rotation axis (right-hand rule).",
    ),
    key("degrees", "float", "°", "required", "Angle."),
    key("center", "vec3", "m", "[0, 0, 0]", "A point on the axis."),
];
pub const ADD_BODY_KEYS: &[Key] = &[key(
    "layout",
    "string",
    "",
    "\"continuous\"",
    "\"continuous\": tetrahedra share nodes (unbreakable). \"jointed\": every tetrahedron owns its 4 nodes (node multiplicity), to be held by joint elements. \"rigid\": the body does not deform; it moves with 6 degrees of freedom (mass and inertia from its tetrahedra), touches others through its surface and costs no element forces (drop weights, platens, shaking tables; docs/theory/integration.md#rigid-bodies). Its nodes cannot be fixed one by one: use `body.fix()` or `body.prescribe_velocity(..)`; it takes no joints.",
)];

pub const BODY_VELOCITY_KEYS: &[Key] = &[
    key("x", "table|float", "m/s", "free", "Velocity of the centre of mass along x (a number or a `table` of time), evaluated at mid-step."),
    key("y", "table|float", "m/s", "free", "Along y."),
    key("z", "table|float", "m/s", "free", "Along z."),
    key("rotation", "string", "", "as before (free)", "\"fixed\": the body does not rotate; \"free\": it rotates under the torques."),
];
pub const BOUNDARY_KEYS: &[Key] = &[
    key(
        "normal",
        "vec3",
        "-",
        "any",
        "Keep faces whose outward normal is within `tolerance` of this direction.",
    ),
    key(
        "tolerance",
        "float",
        "°",
        "1",
        "Angle tolerance for `normal`.",
    ),
    key(
        "within",
        "shape",
        "",
        "anywhere",
        "Keep faces whose centroid lies in this region.",
    ),
];
pub const INTEGRATOR_KEYS: &[Key] = &[
    key("safety", "float", "-", "0.8", "dt = safety × critical time step (exact element bound: never above the true critical step); in [1e-6, 1]."),
    key("dt", "float", "s", "automatic", "Fixed time step; an error if larger than the critical step."),
];
pub const DAMPING_KEYS: &[Key] = &[
    key("mass_proportional", "float", "1/s", "0", "α in the damping force −α·m·(v − v_frame) (dynamic relaxation; critical for mode ω at α = 2ω). At most 2/dt: beyond it the central difference reverses every velocity each step, and the run stops with an error giving the limit."),
    key("frame", "string", "", "\"ground\"", "What velocities are damped relative to: \"ground\" (v_frame = 0, or the ground's velocity under `shake_base`): every motion is resisted, also a body's imposed or free translation; \"body\": each deformable body's centre-of-mass velocity (its translation is not damped, its deformation and rotation are; rigid bodies are not damped). Costs one pass over the nodes per step."),
];
/// `at` of selections and bounds.
pub const SELECT_KEYS: &[Key] = &[key("at", "string", "", "\"reference\"", "Where nodes are tested: \"reference\" (the positions as built: a selection means the same material points whenever it is made) or \"current\" (the positions now).")];
pub const VOLUME_IN_BOX_KEYS: &[Key] = &[
    key("min", "vec3", "m", "required", "Lower corner of the box."),
    key("max", "vec3", "m", "required", "Upper corner of the box."),
    key(
        "at",
        "string",
        "",
        "\"current\"",
        "\"current\" or \"reference\" positions.",
    ),
];
pub const BOUNDS_KEYS: &[Key] = &[key(
    "at",
    "string",
    "",
    "\"current\"",
    "\"current\" (the positions now) or \"reference\" (as built).",
)];
pub const GRAVITY_KEYS: &[Key] = &[
    key("ramp", "float", "s", "required", "Ramp time: g grows linearly from 0 at `start` to its full value at `start` + ramp, then stays."),
    key("start", "float", "s", "now", "Time the ramp starts."),
];
pub const REST_KEYS: &[Key] = &[
    key("ratio", "float", "-", "1e-6", "At rest when the kinetic energy is at most ratio × the work W at two checks in a row; W = max(|external work|, strain energy)."),
    key("max_steps", "int", "steps", "200000", "Step cap: the stage ends there, with a warning, if not at rest."),
    key("check_every", "int", "steps", "50", "How often the kinetic energy is compared (and the adaptive α updated)."),
    key("damping", "float", "1/s", "adaptive", "Mass-proportional α during the stage. Default: 2ω with ω² = 2U/Σm|u|², the Rayleigh quotient of the current displacement u (≈ the lowest mode once the model sags under its load), updated at every check; until something moved, the damping the model had. Rigid bodies are left out of u, but a deformable body's free travel is not: after a fall or a long slide (a poured bed) the estimate is far too low, so give α yourself (critical for the lowest mode ω₁: α = 2ω₁)."),
];
pub const PLOT_KEYS: &[Key] = &[
    key("file", "string", "", "required", "Name of the figure's files, without extension: `<out_dir>/<file>.png` and `.svg` (replaced if there)."),
    key("y", "string|monitor|array", "", "required", "The monitors to plot: a name, a monitor, or an array of them (one line each, with a legend entry)."),
    key("x", "string|monitor", "", "\"time\"", "The x axis: \"time\" [s], \"step\", or a monitor (each y is paired with the x monitor's sample of the same step; give them the same `every`)."),
    key("x_label", "string", "", "name and unit", "Label of the x axis, drawn as given (numbers unscaled). Default: `time [s]` scaled by an SI prefix (`time [ms]`), or the monitor's name and its `unit` (`force [kN]`: an SI prefix where the unit takes one, else a power of ten, `stress [×10³ MPa]`; `(unit not recorded)` for a monitor without one)."),
    key("y_label", "string", "", "name", "Label of the y axis, drawn as given (numbers unscaled). Default as `x_label`: the monitor's name and unit; for several monitors their names and their common unit, or each unit in its legend entry when they differ."),
    key("title", "string", "", "\"<y> against <x>\"", "Title above the plot."),
    key("format", "string", "", "\"both\"", "\"png\", \"svg\" or \"both\"."),
    key("width", "int", "px", "1000", "Width in pixels, in [200, 8000]."),
    key("height", "int", "px", "600", "Height in pixels, in [200, 8000]."),
];
pub const REPARTITION_KEYS: &[Key] = &[
    key(
        "if_moved",
        "float",
        "",
        "0",
        "Split only when at least this fraction of the nodes would change rank (decided from the chunks' centres, a small collective without sharing any node); 0: always.",
    ),
    key(
        "if_imbalance",
        "float",
        "",
        "0",
        "Split only when the ranks' stage work since the last call was at least this unbalanced: the slowest rank's stage time over the mean (1.1: 10 % above it; exchange and waiting not counted; one number per rank gathered). 0: always. With `if_moved` too, both must hold. The results do not depend on it.",
    ),
    key(
        "weigh",
        "string",
        "",
        "\"corners\"",
        "What the split balances: \"corners\", the tet corners at each rank's nodes (every tet costs alike); \"work\", the modelled work besides: joints (4 times as much once damaged, the law's general path; nothing once broken) and contact pairs (30 times as much while touching, the exact kernel, as a candidate's rejection test), from every joint's and pair's state (shared first). For models whose breaking or touching part is where the work is.",
    ),
];
pub const PLOT_ENERGY_KEYS: &[Key] = &[
    key(
        "file",
        "string",
        "",
        "\"energy\"",
        "Name of the figure's files, without extension (`<out_dir>/energy.png` and `.svg`).",
    ),
    key(
        "title",
        "string",
        "",
        "\"Energy account\"",
        "Title above the plot.",
    ),
    key(
        "format",
        "string",
        "",
        "\"both\"",
        "\"png\", \"svg\" or \"both\".",
    ),
    key(
        "width",
        "int",
        "px",
        "1000",
        "Width in pixels, in [200, 8000].",
    ),
    key(
        "height",
        "int",
        "px",
        "800",
        "Height in pixels, in [200, 8000].",
    ),
];
pub const EVERY_KEYS: &[Key] = &[
    key("steps", "int", "steps", "-", "Call every this many steps."),
    key(
        "time",
        "float",
        "s",
        "-",
        "Call each time simulated time passes a multiple of this; at least the time step (shorter is an error at `run`: use `steps: 1`).",
    ),
];
pub const MONITOR_KEYS: &[Key] = &[
    key(
        "every",
        "int",
        "steps",
        "1",
        "Record every this many steps (and once when the run starts).",
    ),
    key(
        "unit",
        "string",
        "",
        "none",
        "Unit of the recorded number (\"N\", \"m\", \"J\", \"MPa\", \"m/s\"; \"-\" for a pure number such as a count or a ratio). Written into the CSV header as `name [unit]` and put on plot axes (`force [kN]`, scaled by an SI prefix where the unit takes one). Without it the axis says `(unit not recorded)`. Not empty, no brackets.",
    ),
];
pub const RUN_KEYS: &[Key] = &[
    key("max_time", "float", "s", "-", "Stop when the simulated time reaches this value (absolute)."),
    key("duration", "float", "s", "-", "Run for this much simulated time from now."),
    key("steps", "int", "steps", "-", "Run this many steps."),
    key("stop_when", "closure", "", "-", "Stop as soon as `|s| …` returns true (checked after each `check_every` steps). Needs one of the limits above too."),
    key("check_every", "int", "steps", "1", "How often `stop_when` is evaluated."),
];
pub const INSERT_JOINTS_KEYS: &[Key] = &[
    key(
        "within",
        "body or array of bodies",
        "",
        "-",
        "Jointed bodies whose internal faces get joints (give this or `between`).",
    ),
    key(
        "between",
        "body or array of bodies",
        "",
        "-",
        "Bodies (jointed or continuous) whose coincident boundary faces get joints: mortar between blocks, a block glued to a base. Faces must match vertex for vertex.",
    ),
    key(
        "gap_tolerance",
        "float",
        "m",
        "1e-9 × model size",
        "With `between`: how far apart matching vertices may be.",
    ),
    key("law", "JointLaw", "", "required", "From `joint_law(..)`."),
    key(
        "region",
        "shape",
        "",
        "everywhere",
        "With `within`: only faces whose centroid lies in this region.",
    ),
];
pub const CONTACT_LAW_KEYS: &[Key] = &[key(
    "between",
    "[material, material]",
    "",
    "all pairs",
    "Apply to this pair of materials only (later calls override earlier ones).",
)];
pub const CONTACT_DETECTION_KEYS: &[Key] = &[
    key("skin", "float", "m", "¼ of the mean surface element size", "Boxes are inflated by skin/2; detection runs again only when a node has moved more than skin/2 since the last one (no contact can be missed)."),
];
pub const VELOCITY_KEYS: &[Key] = &[
    key(
        "x",
        "table|float",
        "m/s",
        "free",
        "Velocity along x (a number or a `table`).",
    ),
    key("y", "table|float", "m/s", "free", "Velocity along y."),
    key("z", "table|float", "m/s", "free", "Velocity along z."),
];

pub const API: &[FnDoc] = &[
    // ── Parameters and checks
    FnDoc { section: "Parameters and checks", name: "params", signature: "params(#{ name: default, … }) -> map",
        summary: "Declare the script's parameters with defaults. `fdem run … --set name=value` overrides them (the value is parsed with the default's type); an unknown name is an error that lists the parameters.", keys: &[], laws: &[] },
    FnDoc { section: "Parameters and checks", name: "expect_within", signature: "expect_within(label, value, low, high)",
        summary: "Self-check: fail the script (with its line) unless low ≤ value ≤ high. Skipped by `fdem check`.", keys: &[], laws: &[] },
    FnDoc { section: "Parameters and checks", name: "expect_near", signature: "expect_near(label, value, reference, rel_tol)",
        summary: "Self-check: fail unless |value − reference| ≤ rel_tol·|reference|. Skipped by `fdem check`.", keys: &[], laws: &[] },
    FnDoc { section: "Parameters and checks", name: "fmt", signature: "fmt(x, digits [, unit]) -> string",
        summary: "A number for printing: `x` (a float, an int or an array of them) with `digits` (1 to 17) significant digits, trailing zeros dropped, in fixed notation when 0.001 ≤ |x| < 10⁶ after rounding and in scientific notation otherwise (`1.5e-7`, `2.4e12`); `unit`, if given, follows after a space. ``print(`mass ${fmt(beam.mass, 4, \"kg\")}`)`` prints `mass 157 kg`, where `${beam.mass}` prints `157.00000000000065`. Only for output to read: files written by the engine keep every digit.", keys: &[], laws: &[] },
    // ── Simulation
    FnDoc { section: "Simulation", name: "simulation", signature: "simulation(#{ … }) -> Simulation", summary: "Create an empty model.", keys: SIMULATION_KEYS, laws: &[] },
    FnDoc { section: "Simulation", name: "sim.integrator", signature: "sim.integrator(\"central_difference\", #{ … })",
        summary: "Time-integration options (stage 7). The chosen dt is printed with the element that sets the critical step.", keys: INTEGRATOR_KEYS, laws: &[] },
    FnDoc { section: "Simulation", name: "sim.damping", signature: "sim.damping(#{ … })", summary: "Mass-proportional damping for quasi-static stages; set 0 to switch it off between runs. It resists every velocity relative to its frame, also imposed ones: under a platen or loading point driven at a speed, the damping force of the nodes that move with it adds to the reaction (about α·v·(moving mass)). For loading by prescribed motion use `frame: \"body\"` (a body's translation is not damped), load slowly against the period of the first mode, or bring the model to rest between load steps with `sim.bring_to_rest(..)` and switch damping off while loading; a material's `viscosity` is damping on the strain rate alone (stiffness-proportional).", keys: DAMPING_KEYS, laws: &[] },
    FnDoc { section: "Simulation", name: "sim.bring_to_rest", signature: "sim.bring_to_rest(#{ … }) -> #{ converged, steps, time, kinetic, work, ratio, damping }",
        summary: "A dynamic-relaxation stage: run with mass-proportional damping until the kinetic energy stays below `ratio` × the work done on the model, or `max_steps` (then a warning, and `converged` is false). The damping of the model is restored afterwards; monitors, hooks and output run as in `sim.run`. It cannot end while something is driven at a speed (a prescribed velocity) or slides freely. Example, a column settled under its weight: `sim.gravity([0.0, 0.0, -9.81]); let r = sim.bring_to_rest(#{ ratio: 1e-8 }); print(r.steps);`.", keys: REST_KEYS, laws: &[] },
    FnDoc { section: "Simulation", name: "sim.run", signature: "sim.run(#{ … })",
        summary: "Advance the model. Runs are staged: each continues from where the last stopped. Needs max_time, duration or steps.", keys: RUN_KEYS, laws: &[] },
    // ── Materials
    FnDoc { section: "Materials", name: "material", signature: "material(law, #{ … }) -> Material",
        summary: "An elastic material. `law`: \"elastic/small_strain\" (Hooke, linear strain; not objective), \"elastic/st_venant_kirchhoff\" (Green–Lagrange strain, PK2 stress), \"elastic/munjiza\" (left Cauchy–Green, Cauchy stress; Munjiza 2004 eq. 4.220), \"elastic/neo_hookean\" (compressible), each from `young` and `poisson`; \"elastic/mooney_rivlin\" (compressible Mooney–Rivlin for rubber-like solids) from `c10`, `c01` and `bulk` (small-strain shear modulus 2(c10 + c01)). Properties: `young`, `poisson` (for Mooney–Rivlin the small-strain values), `c10`, `c01`, `bulk`, `density`, `viscosity`, `law`.", keys: crate::material::MATERIAL_COMMON_PARAMS, laws: crate::material::MATERIAL_LAWS },
    // ── Geometry
    FnDoc { section: "Geometry and meshes", name: "box", signature: "box(#{ … }) -> Shape", summary: "Axis-aligned box. Meshable and usable as a region.", keys: BOX_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "sphere", signature: "sphere(#{ … }) -> Shape", summary: "Sphere (region).", keys: SPHERE_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "cylinder", signature: "cylinder(#{ … }) -> Shape", summary: "Finite cylinder (region).", keys: CYLINDER_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "half_space", signature: "half_space(#{ … }) -> Shape", summary: "Half-space (region).", keys: HALF_SPACE_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "shape.mesh", signature: "shape.mesh(#{ … }) -> Mesh",
        summary: "Mesh a shape into tetrahedra. Boxes: structured, 6 Kuhn tetrahedra per cell (conforming). Cylinders: an O-grid cross-section (square core, four blocks mapped onto the circle) extruded along the axis, prisms cut into 3 tetrahedra; sets `bottom`, `top`, `side`. Spheres: a cube grid mapped onto the ball, 6 tetrahedra per cell; set `surface`. Curved faces have their nodes on the surface (volume error O(size²)). Half-spaces are regions only.", keys: MESH_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "tet_mesh", signature: "tet_mesh(#{ … }) -> Mesh", summary: "A mesh from explicit nodes and tetrahedra.", keys: TET_MESH_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "mesh.translate", signature: "mesh.translate([dx, dy, dz]) -> Mesh", summary: "Move the mesh (in place; also returns it) [m].", keys: &[], laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "mesh.rotate", signature: "mesh.rotate(#{ … }) -> Mesh", summary: "Rotate the mesh (in place; also returns it).", keys: ROTATE_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "gmsh", signature: "gmsh(path [, #{ … }]) -> Mesh",
        summary: "Import a Gmsh mesh: a `.msh` file (MSH 4.1 ASCII or binary, 2.2 ASCII) or a `.geo` file meshed by the `gmsh` executable (`gmsh -3`; it must be installed). `path` is relative to the script's directory. 4-node tetrahedra become the mesh; physical groups become named sets (volumes → element sets; surfaces → face sets and node sets; curves and points → node sets; unnamed groups are `physical_<tag>`). Nodes used by no tetrahedron are dropped and left-handed tetrahedra reordered, each with a warning; other 3D element types, surface triangles that are not tetrahedron faces, and mesh problems (degenerate, duplicate or folded tetrahedra, non-manifold faces) are errors naming the element and its place. A `.geo` file that runs programs (gmsh's `SystemCall`, `Shell`, `OnelabRun`, also in files it includes) is refused unless `fdem run --allow-geo-commands`; gmsh writes into a private temporary directory and is stopped after 600 s (`--gmsh-timeout SECONDS`); the mesh is kept in `.fdem-cache/` beside the `.geo` (keyed by its text, `size` and the gmsh version) and reused by later `fdem check` and `fdem run` calls, each saying which file it used. Files are read up to 8 GB (a device or pipe up to 256 MB). See docs/meshing.md.", keys: GMSH_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "mesh.sets", signature: "mesh.sets() -> array", summary: "Names of the mesh's sets (sorted). `body.sets()` gives those of a body.", keys: &[], laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "mesh.scale", signature: "mesh.scale(factor | [sx, sy, sz] [, center]) -> Mesh",
        summary: "Scale about `center` (default the origin), in place; also returns the mesh. Factors must be non-zero; a negative product mirrors the mesh, and node order is then reversed so volumes stay positive. Sets are kept.", keys: &[], laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "mesh.mirror", signature: "mesh.mirror(#{ … }) -> Mesh",
        summary: "Mirror across a plane, in place; also returns the mesh. Node order is reversed so volumes stay positive; sets (also face sets) name the mirrored elements, nodes and faces.", keys: MIRROR_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "array", signature: "array(mesh, #{ … }) -> array of Mesh",
        summary: "Copies of a mesh on a regular grid (the first at the mesh's own place, x varying fastest), each with the mesh's sets. Add them as separate bodies: `let m = array(brick, #{ count: [4, 1, 3], spacing: [0.2, 0.0, 0.1] }); for i in 0..m.len() { sim.add_body(\"brick_\" + i, m[i], rock); }`.", keys: ARRAY_KEYS, laws: &[] },
    FnDoc { section: "Geometry and meshes", name: "mesh.copy", signature: "mesh.copy() -> Mesh", summary: "An independent copy. Properties: `n_nodes`, `n_tets`, `volume` [m³].", keys: &[], laws: &[] },
    // ── Generators
    FnDoc { section: "Generators", name: "disc", signature: "disc(#{ … }) -> Mesh",
        summary: "A disc (short cylinder) centred on `center`: the mesh of `cylinder(..).mesh(..)`. Sets `bottom`, `top` (the faces at −axis and +axis), `side`, element set `all`.", keys: DISC_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "hollow_cylinder", signature: "hollow_cylinder(#{ … }) -> Mesh",
        summary: "A tube: a periodic annular (r, θ) grid extruded along the axis, prisms cut into 3 tetrahedra. Sets `inner`, `outer`, `bottom`, `top`.", keys: HOLLOW_CYLINDER_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "notched_beam", signature: "notched_beam(#{ … }) -> Mesh",
        summary: "The three-point-bending specimen: a beam with a notch from the bottom at mid-span, structured boxes (6 Kuhn tetrahedra each, mirrored about mid-span) refined towards the notch. Face + node sets `top`, `bottom`, `notch`, `left_end`, `right_end`, `front`, `back`; node sets `load_line` (top, mid-span), `support_left`, `support_right`, `supports` (bottom, at ±span/2).", keys: NOTCHED_BEAM_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "biconcave_cell", signature: "biconcave_cell(#{ … }) -> Mesh",
        summary: "A red blood cell: the Evans–Fung biconcave disc z = ±½√(1 − ρ²)(C₀ + C₁ρ² + C₂ρ⁴), ρ = r/R₀ (defaults: the human cell, 7.82 µm across, 94.1 µm³), meshed by mapping the unit ball's mesh onto it, so surface nodes lie exactly on the surface. Sets `surface`, `top`, `bottom` (faces + nodes), element set `all`.", keys: BICONCAVE_CELL_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "random_packing", signature: "random_packing(mesh, #{ … }) -> Assembly",
        summary: "Copies of a mesh placed at random in a box without overlapping (random sequential addition: uniformly random orientation and position, redrawn while it intersects a copy already placed, tested exactly tet against tet), as an assembly of one block per copy for `sim.add_blocks`. The loose initial state of a packing to pour under gravity. Random sequential addition stops near a solid fraction of 0.38 for spheres, less for flat shapes: a box asked to hold more is an error saying how many copies fitted.", keys: RANDOM_PACKING_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "arch", signature: "arch(#{ … }) -> Assembly",
        summary: "Voussoirs of a circular arch, each a structured (r, θ, y) grid of prisms cut into tetrahedra. Block 0 is the springer at +x, the last block the springer at −x; with the default centre a semicircular arch springs from z = 0. Sets per block: `intrados`, `extrados`, `joint_right` (towards +x), `joint_left`, `front`, `back`, and `springing` on the springers. Neighbouring voussoirs share their joint faces exactly.", keys: ARCH_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "wall", signature: "wall(#{ … }) -> Assembly",
        summary: "Bricks in running bond with straight ends (half bricks at the ends of odd courses), each brick a Kuhn box mesh. Sets per brick: `top`, `bottom`, `left`, `right`, `front`, `back`. Bricks of course 0 are springers. With zero gaps neighbouring bricks share faces triangle for triangle.", keys: WALL_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "dome", signature: "dome(#{ … }) -> Assembly",
        summary: "Voussoir blocks of a spherical dome with an oculus, in courses from the base (course 0, springers) to the crown, running bond. Each block is a spherical-shell patch meshed structured in (θ, φ, r). Sets per block: `intrados`, `extrados`, `bed_lower`, `bed_upper`, `head_left` (smaller longitude), `head_right`, and `base` on course 0. Neighbouring blocks share faces exactly.", keys: DOME_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "cloister_vault", signature: "cloister_vault(#{ … }) -> Assembly",
        summary: "An octagonal cloister vault with a pointed profile, the dome of Santa Maria del Fiore in outline (one shell): eight webs, each a cylinder with a horizontal axis parallel to its side, springing at z = 0 and cut at the oculus. The pointed profile circle of radius r = profile_ratio · D_c lies on the eight corner ribs by default (`profile: \"corners\"`: (q − q_c)² + z² = r² in each corner plane, q the distance from the axis, q_c = D_c/2 − r; the web mid-lines are elliptical) or on the web mid-lines (`profile: \"webs\"`: (s − s_c)² + z² = r², s_c = span/2 − r; elliptical corners). Courses of blocks in running bond from the springing (course 0, springers) to the oculus, each block a structured (ψ, around, ρ) grid of prisms cut into tetrahedra; blocks are numbered per course counter-clockwise from corner 0 (+x). Sets per block: `intrados`, `extrados`, `bed_lower`, `bed_upper`, `head_left` (clockwise edge), `head_right`, `base` (course 0), `oculus` (top course), `rib` (rib blocks: free faces beyond the web). Neighbouring blocks share faces exactly, also across the corners. Example: `let v = cloister_vault(#{ span: 45.0, thickness: 2.2, courses: 12, blocks_per_web: 4, oculus: 5.6, size: 1.0 });` (Florence in outline, circle on the corners: 384 blocks, 27 648 tetrahedra).", keys: CLOISTER_VAULT_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "assembly.block", signature: "assembly.block(i) -> #{ index, course, springer, mesh }",
        summary: "Block i of an assembly: its index in its course, its course, whether it rests on a support, and its mesh (also `assembly.mesh(i)`). Properties: `n_blocks` (also `len()`), `n_courses`, `n_tets`, `volume` [m³], `kind`; `assembly.quality()` as `mesh.quality()`.", keys: &[], laws: &[] },
    FnDoc { section: "Generators", name: "sim.add_blocks", signature: "sim.add_blocks(assembly, material [, #{ … }]) -> Array of Body",
        summary: "Add every block of an assembly as a body, in block order (body i is `assembly.block(i)`). Glue them with `sim.insert_joints(#{ between: bodies, law })`.", keys: ADD_BLOCKS_KEYS, laws: &[] },
    FnDoc { section: "Generators", name: "mesh.quality", signature: "mesh.quality() -> #{ min_dihedral, max_dihedral, max_aspect_ratio, mean_aspect_ratio }",
        summary: "Element quality: smallest and largest dihedral angle [°] and aspect ratio (longest edge over inradius, 1 for the regular tetrahedron).", keys: &[], laws: &[] },
    // ── Bodies
    FnDoc { section: "Bodies and selections", name: "sim.add_body", signature: "sim.add_body(name, mesh, material [, #{ … }]) -> Body",
        summary: "Place a mesh in the model. The mesh is checked: inverted, degenerate or duplicate tetrahedra, non-manifold faces, tetrahedra folding over a neighbour and nodes used by no tetrahedron are errors naming the element and its place. When the first run starts, bodies whose tetrahedra intersect are an error naming both bodies and the elements (touching is fine). Properties: `name`, `n_tets`, `n_nodes`, `volume` [m³], `mass` [kg], `layout`. A body of more than 2048 nodes (stage 7's chunk; a jointed body has 4 per tetrahedron) is stored in spatial order, its tetrahedra along a Z-order curve of their centroids and its nodes in the order they first use them, so that every stage's runs of consecutive elements are compact pieces of it (and a rank's share on `mpirun`): its tet and node ids, in messages and output, are the body's, not the mesh file's (the mesh's checks above name the file's); its sets follow.", keys: ADD_BODY_KEYS, laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.copy", signature: "body.copy(name) -> Body", summary: "Add a copy of the body (same mesh, material and layout, at its current reference placement).", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.translate", signature: "body.translate([dx, dy, dz])", summary: "Move a body before the first step [m].", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.rotate", signature: "body.rotate(#{ … })", summary: "Rotate a body before the first step.", keys: ROTATE_KEYS, laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.nodes", signature: "body.nodes([shape [, #{ at }]]) -> Nodes", summary: "The body's nodes, or those inside a region (surface included, tolerance 1e-9 × model size), tested at their reference positions by default: the same nodes before, during and after a run, however far the body moved (`#{ at: \"current\" }` tests the positions now).", keys: SELECT_KEYS, laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.set", signature: "body.set(name) -> Faces | Elements | Nodes",
        summary: "A named set of the body's mesh (from Gmsh physical groups) as a selection: a surface group gives its faces (`faces.nodes()` their nodes), a volume group its elements, a curve or point group its nodes. An unknown name is an error listing the body's sets.", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.node_set", signature: "body.node_set(name), body.element_set(name), body.face_set(name)",
        summary: "A named set of one kind, for names used by several kinds. `node_set` gives every copy of the set's nodes (in a jointed body each tetrahedron has its own), so `sim.fix(body.node_set(\"base\"))` holds every tetrahedron touching the base; a face set's `nodes()` holds only the nodes of its faces' own tetrahedra.", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "sim.nodes", signature: "sim.nodes(shape [, #{ at }]) -> Nodes", summary: "Nodes of all bodies inside a region (reference positions unless `at: \"current\"`).", keys: SELECT_KEYS, laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.elements", signature: "body.elements([shape [, #{ at }]]) -> Elements", summary: "The body's tetrahedra, or those whose centroid is inside a region (reference positions unless `at: \"current\"`).", keys: SELECT_KEYS, laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.boundary", signature: "body.boundary([#{ … }]) -> Faces", summary: "Outer boundary faces of the body, optionally filtered. `faces.nodes()` gives their nodes, `faces.area` their area [m²].", keys: BOUNDARY_KEYS, laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.set_velocity", signature: "body.set_velocity([vx, vy, vz])",
        summary: "Give every point of the body the velocity [m/s] now, without spin (an initial condition; rigid or deformable).", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.set_spin", signature: "body.set_spin([wx, wy, wz] [, centre])",
        summary: "Spin the body at ω [rad/s] about the axis through `centre` [m] (default: its centre of mass) on top of the velocity V its centre of mass had: v(x) = V + ω × (x − centre). A rigid body gets the angular momentum L = I·ω (exact inertia).", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.fix", signature: "body.fix()",
        summary: "Hold the body: a rigid body does not move or rotate (`body.reaction()` and `body.reaction_torque()` report what holds it); a deformable body has all its nodes fixed.", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.prescribe_velocity", signature: "body.prescribe_velocity(#{ … })",
        summary: "Impose the velocity of a rigid body's centre of mass per component [m/s] (numbers or tables of time; later calls win per component) and hold or free its rotation (a platen at constant speed: `#{ z: -0.01, x: 0.0, y: 0.0, rotation: \"fixed\" }`). An error for a deformable body (use `sim.prescribe_velocity(body.nodes(), ..)`).", keys: BODY_VELOCITY_KEYS, laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.center_of_mass", signature: "body.center_of_mass(), body.velocity() -> [x, y, z]",
        summary: "Centre of mass now [m] and its velocity at the last half step [m/s] (rigid or deformable).", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "sim.volume_in_box", signature: "sim.volume_in_box(bodies, #{ … }) -> float",
        summary: "Volume [m³] of the bodies inside an axis-aligned box, each tetrahedron clipped to the box exactly (divergence theorem over the clipped faces). Divided by the box's volume it is the solid fraction of a packing measured in a core region away from the walls; overlaps of bodies in contact count twice.", keys: VOLUME_IN_BOX_KEYS, laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.bounds", signature: "mesh.bounds(), body.bounds([#{ at }]) -> #{ min, max, center, size }",
        summary: "Axis-aligned bounding box [m] of a mesh's nodes, or of a body's nodes now (or `at: \"reference\"`). Curved generated surfaces are polygons: a box's extremes are vertices, not the ideal surface (docs/generators.md says where each generator's vertices lie). `print(disc(#{ radius: 0.025, thickness: 0.01 }).bounds().max)` gives `[0.025, 0.025, 0.005]`.", keys: BOUNDS_KEYS, laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.momentum", signature: "body.momentum(), body.angular_momentum([point]) -> [x, y, z]",
        summary: "Linear momentum M·V [kg·m/s] and angular momentum [kg·m²/s] about `point` (default: the centre of mass now) of a body, from the last half-step velocities. Rigid bodies: exact inertia, L_c + M(c − p) × V. Deformable bodies: Σ m(x − p) × v with the lumped nodal masses (the lumped inertia differs from the exact one by O(h²)); with no external moment the central difference keeps it constant to round-off.", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.place_against", signature: "body.place_against(other, axis [, gap]) -> [dx, dy, dz]",
        summary: "Move the body along one axis so that its bounding box touches `other`'s (or faces it across `gap` [m]) before the first step; returns the translation. `axis` \"x\", \"y\" or \"z\" keeps the body on the side of `other` where its centre is; \"+y\" puts it on the +y side, \"-y\" on the −y side. The boxes touch, so curved bodies touch at their extreme vertex: `platen.place_against(disc, \"+y\")` sets a platen on top of a Brazilian disc.", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "body.force", signature: "body.force(), body.torque(), body.acceleration(), body.mass_acceleration(), body.angular_velocity(), body.reaction(), body.reaction_torque() -> [x, y, z]; body.inertia() -> 3×3",
        summary: "A rigid body in the last step: resultant of the nodal forces on it (contact and applied loads, without gravity and the constraint) [N] and their moment about the centre of mass [N·m]; acceleration of the centre of mass (V(t+dt/2) − V(t−dt/2))/dt̄ [m/s²] and mass × acceleration [N] (= force + weight + reaction); angular velocity [rad/s]; force and torque of the constraint (`fix`, `prescribe_velocity`) [N], [N·m]; inertia tensor about the centre of mass in the current orientation [kg·m²]. An error naming the body if it is not rigid.", keys: &[], laws: &[] },
    FnDoc { section: "Bodies and selections", name: "set + set", signature: "nodes + nodes -> Nodes", summary: "Union of node sets (also for elements). All sets have `len()`.", keys: &[], laws: &[] },
    // ── Joints and fracture
    FnDoc { section: "Joints and fracture", name: "joint_law", signature: "joint_law(law, #{ … }) -> JointLaw",
        summary: "A joint law by name; each law takes its own keys (a key of another law is an error that says which laws take it).", keys: &[], laws: crate::joints::law::JOINT_LAWS },
    FnDoc { section: "Joints and fracture", name: "sim.insert_joints", signature: "sim.insert_joints(#{ … }) -> int",
        summary: "Insert joints on every internal face of jointed bodies (`within`, optionally inside a region) or on the coincident faces of different bodies (`between`); returns how many. Faces that already have a joint are skipped.", keys: INSERT_JOINTS_KEYS, laws: &[] },
    FnDoc { section: "Joints and fracture", name: "sim.fracture_criterion", signature: "sim.fracture_criterion(#{ … })",
        summary: "A user rule for when joints break, written in Rhai and compiled like the joint laws. A joint broken by it before full damage releases its stored energy as fracture dissipation.", keys: crate::fracture::CRITERION_PARAMS, laws: &[] },
    FnDoc { section: "Joints and fracture", name: "sim.on_joint_broken", signature: "sim.on_joint_broken(|s, joint| …)",
        summary: "Called after each step for every joint that broke (all its points reached D = 1): `joint` is #{ id, time, centroid, mode (\"I\", \"II\", \"mixed\"), body (name of the body on side A), bodies ([id A, id B]: indices of the two bodies in the order they were added; for `sim.add_blocks` added first, block indices), normal (unit normal of the joint face in the reference configuration, from side A to side B) }. Every run also writes `cracks.csv`.", keys: &[], laws: &[] },
    FnDoc { section: "Joints and fracture", name: "s.fragments", signature: "s.fragments() -> #{ count, volumes, masses }",
        summary: "Fragments: connected components of tetrahedra over intact joints and shared nodes, with their volumes [m³] and masses [kg]. Also `s.broken_joints()`, `s.damaged_joints()` (joints with damage D > 0 at a point: softening or broken) and `s.n_joints`.", keys: &[], laws: &[] },
    // ── Reinforcement
    FnDoc { section: "Reinforcement", name: "steel", signature: "steel(#{ … }) -> Steel, steel(law, #{ … }) -> Steel",
        summary: "A uniaxial steel for rebars: `steel(#{ yield_stress, … })` is the built-in \"bilinear\" law (elastic–plastic, linear isotropic hardening from `hardening` or from `ultimate_stress` at `ultimate_strain`, rupture at `ultimate_strain`, optional Cowper–Symonds rate factor); `steel(\"script\", #{ function, … })` a law written in Rhai.", keys: &[], laws: crate::elements::bar2::steel::STEEL_LAWS },
    FnDoc { section: "Reinforcement", name: "bond_law", signature: "bond_law(law, #{ … }) -> BondLaw",
        summary: "The bond stress–slip law between a bar and its host: \"fib2010\" (fib Model Code 2010 for confined concrete, concrete with stirrups, or unconfined concrete) or \"script\" (an envelope τ_env(s) in Rhai). Unloading is elastic with the law's stiffness; the strength follows the envelope at the largest slip so far.", keys: &[], laws: crate::joints::bond::BOND_LAWS },
    FnDoc { section: "Reinforcement", name: "sim.rebar", signature: "sim.rebar(host, #{ … }) -> Rebar",
        summary: "Lay a bar along a polyline inside the body `host` (jointed or continuous): bar elements of the steel, each bar node tied to the host tetrahedron holding it by a bond point. The bar follows the fragments when the host cracks; it touches other bodies only through its host. Before the first step. A point outside the host is an error naming it. Rebar queries: `r.name`, `r.bars` (count), `r.nodes([shape])` (its bar nodes, e.g. to hold a bar's end on a symmetry plane), `r.axial_forces()` [N], `r.max_force()` [N], `r.max_stress()` [Pa], `r.max_plastic_strain()`, `r.max_bending_moment()` [N·m], `r.ruptured()` (bars broken), `r.max_slip()` [m]. `write_vtk` also writes `<name>_bars_NNNNNN.vtu` (lines with axial_force, stress, strain, plastic_strain, rebar, ruptured; points with slip, bond_stress and bending_moment). Bars bend at their nodes (`bending`, on by default): a bar crossing a sliding crack carries dowel force up to its plastic moment.", keys: REBAR_KEYS, laws: &[] },
    FnDoc { section: "Reinforcement", name: "straight_bar", signature: "straight_bar(host, #{ … }) -> array",
        summary: "The two end points of a straight bar along an axis of a box-like host, at given section coordinates, `cover` short of the host's ends: `sim.rebar(beam, #{ points: straight_bar(beam, #{ axis: \"x\", at: [y, z], cover: 0.04 }), … })`.", keys: STRAIGHT_BAR_KEYS, laws: &[] },
    FnDoc { section: "Reinforcement", name: "stirrup", signature: "stirrup(host, #{ … }) -> array",
        summary: "A closed rectangular stirrup (5 points, the last repeating the first) in the host's section normal to `axis` at `at`, with `cover` to its outer surface.", keys: STIRRUP_KEYS, laws: &[] },
    // ── Loads
    // ── Contact
    FnDoc { section: "Contact", name: "sim.contact_law", signature: "sim.contact_law(\"potential\", #{ … })",
        summary: "Switch contact on (between all bodies, fragments and crack faces) or set it for one pair of materials. Broken joints hand their faces over to contact.", keys: CONTACT_LAW_KEYS, laws: crate::contact_interaction::CONTACT_LAWS },
    FnDoc { section: "Contact", name: "friction_law", signature: "sim.contact_law(\"potential\", #{ friction_law: #{ … }, … })",
        summary: "A friction law written in Rhai: μ of each touching pair, every step, from its kinematics, compiled once to native code like the joint laws. The value must be finite and ≥ 0, or the run stops naming the function and its inputs. Example: `fn mu(c, p) { p.mu0 + p.k * c.slip_rate }` with `friction_law: #{ function: \"mu\", params: #{ mu0: 0.5, k: 2.0 } }`.", keys: crate::contact_interaction::FRICTION_LAW_PARAMS, laws: &[] },
    FnDoc { section: "Contact", name: "sim.contact_detection", signature: "sim.contact_detection(#{ … })", summary: "Options of the NBS contact detection (stage 4).", keys: CONTACT_DETECTION_KEYS, laws: &[] },
    FnDoc { section: "Contact", name: "sim.on_new_contact_pair", signature: "sim.on_new_contact_pair(|s, pair| …)", summary: "Call a closure for every pair of elements that starts touching, with `#{ time, point, bodies, elements }`.", keys: &[], laws: &[] },
    FnDoc { section: "Contact", name: "s.contact", signature: "s.contact() -> #{ … }", summary: "Contact in the last step: `pairs` (candidates), `active` (touching pairs of tetrahedra), `surface_elements`, `normal_force` and `friction_force` (sums of magnitudes over pairs) [N], `energy` [J], `detections` (full detections), `incremental_detections` (joints broke and only the pairs they made possible were added), `max_overlap` (deepest penetration of a touching pair) [m], `max_overlap_ratio` (that over the smaller element height), `max_pressure` (largest mean pressure |F_n|/A of a pair) [Pa], `area` (Σ of the pairs' contact areas) [m²].", keys: &[], laws: &[] },
    FnDoc { section: "Contact", name: "s.contact_force", signature: "s.contact_force(body) -> [fx, fy, fz]", summary: "Total contact force on a body in the last step [N] (what the others exert on it). Record its history with a monitor: `sim.monitor(\"impact\", #{ every: 10 }, |s| s.contact_force(weight)[2])`.", keys: &[], laws: &[] },
    FnDoc { section: "Loads and constraints", name: "sim.gravity", signature: "sim.gravity([gx, gy, gz] [, table | #{ ramp, start }])", summary: "Gravitational acceleration [m/s²] on every node; optionally scaled by a `table` of time, or ramped linearly from 0 over `ramp` seconds (a sudden load makes a structure vibrate about its static state with the static deflection as amplitude; a ramp over several periods of its first mode leaves little: `sim.gravity([0.0, 0.0, -9.81], #{ ramp: 0.05 })`). The work of a varying g is booked as it changes.", keys: GRAVITY_KEYS, laws: &[] },
    FnDoc { section: "Loads and constraints", name: "sim.fix", signature: "sim.fix(nodes [, \"xyz\"])", summary: "Fix all (or the listed) displacement components of the nodes.", keys: &[], laws: &[] },
    FnDoc { section: "Loads and constraints", name: "sim.prescribe_velocity", signature: "sim.prescribe_velocity(nodes, [vx, vy, vz] | #{ … })",
        summary: "Impose the velocity of components [m/s]; each a number or a `table` of time. The reaction is reported by `s.reaction(nodes)`.", keys: VELOCITY_KEYS, laws: &[] },
    FnDoc { section: "Loads and constraints", name: "sim.nodal_force", signature: "sim.nodal_force(nodes, [fx, fy, fz] [, table])", summary: "Force on each node [N], optionally scaled by a table of time.", keys: &[], laws: &[] },
    FnDoc { section: "Loads and constraints", name: "sim.traction", signature: "sim.traction(faces, [tx, ty, tz] [, table])",
        summary: "Surface traction [Pa] on the reference area of faces (dead load), lumped as area/3 to each face node; optionally scaled by a table.", keys: &[], laws: &[] },
    FnDoc { section: "Loads and constraints", name: "sim.initial_velocity", signature: "sim.initial_velocity(nodes, [vx, vy, vz])", summary: "Set the velocity of nodes now [m/s] (before the first step: the initial condition).", keys: &[], laws: &[] },
    FnDoc { section: "Loads and constraints", name: "table", signature: "table([[t0, v0], [t1, v1], …]) -> Table", summary: "Piecewise-linear function of time, held constant beyond its ends. Times must increase. `table.at(t)` is its value at time t.", keys: &[], laws: &[] },
    FnDoc { section: "Loads and constraints", name: "read_table", signature: "read_table(path [, scale]) -> Table", summary: "A table from a text file of two columns (t, value), separated by commas or spaces; `#` lines and a non-numeric header are skipped. Values are multiplied by `scale`. Files larger than 256 MB (or a device that never ends) are refused.", keys: &[], laws: &[] },
    // ── Earthquake records
    FnDoc { section: "Earthquake records", name: "ground_motion", signature: "ground_motion(path [, #{ … }]) -> GroundMotion",
        summary: "Read an acceleration record (path as given, or next to the script): PEER NGA `.AT2` (4 header lines, `NPTS=` and `DT=` on the 4th), two-column `t, a` (commas or spaces, uniform step) or one-column at a given `dt`. Processed in this order: units to m/s², time window, baseline correction, scaling. Bad files are refused with the file and line. Properties (SI units): `dt` [s], `duration` [s], `pga` [m/s², signed], `pga_time` [s], `pgv` [m/s, signed], `pgd` [m, signed], `arias` [m/s], `significant_duration` (D5-95) [s].", keys: GROUND_MOTION_KEYS, laws: &[] },
    FnDoc { section: "Earthquake records", name: "record.at", signature: "record.at(t), record.velocity_at(t), record.displacement_at(t)",
        summary: "Ground acceleration [m/s²] (linear between samples, zero after the record), velocity [m/s] and displacement [m] (integrated from rest as the central-difference step does; after the record the final velocity is held, zero with `baseline`).", keys: &[], laws: &[] },
    FnDoc { section: "Earthquake records", name: "record.spectrum", signature: "record.spectrum(periods, damping) -> array",
        summary: "Pseudo-acceleration response spectrum Sa(T) = ω²·max|u| [m/s²] of linear oscillators with periods `periods` [s] and damping ratio `damping` (0.05 for 5 %), integrated exactly for the piecewise-linear record (Nigam & Jennings 1969). Each period T costs N + T/dt steps (N samples of step dt); more than 1e8 steps in all is an error.", keys: &[], laws: &[] },
    FnDoc { section: "Earthquake records", name: "sim.shake_base", signature: "sim.shake_base(nodes, #{ x, y, z, start })",
        summary: "Way (a), prescribed base motion: the nodes (a base body, a foundation, a shaking table) follow the ground in all three components (directions without a record stay still), over any other prescription of theirs. The ground is the records integrated with the engine's own step from rest at `start` (its displacement is the record's double integral at the simulation step; records with another dt are interpolated). The structure is moved through whatever holds it to the base: shared elements, joints, or contact and friction alone. Mass damping then acts on velocities relative to the ground. The earthquake's input is booked as constraint (reaction) work. Several base motions may drive different node sets.", keys: SHAKE_KEYS, laws: &[] },
    FnDoc { section: "Earthquake records", name: "sim.shake_relative", signature: "sim.shake_relative(#{ x, y, z, start })",
        summary: "Way (b), the relative frame: every node carries the body force −m·a_g(t) (added to gravity's acceleration), so displacements and velocities are relative to the ground; fix the base yourself (`sim.fix(base)`). Its work is the energy term `ground_work`. For a structure whose base is fixed this gives the same relative response as `shake_base` (identical to round-off for the same records and dt; tested).", keys: SHAKE_KEYS, laws: &[] },
    FnDoc { section: "Earthquake records", name: "s.ground", signature: "s.ground() -> #{ acceleration, velocity, displacement, start, end }",
        summary: "The first shaking's ground: acceleration applied on the last step [m/s²], velocity v(t − dt/2) [m/s] (the half-step value, as node velocities), displacement at t [m] (3-arrays), the start time and the time the longest record ends [s]. Relative displacement under `shake_base` = node displacement − ground displacement.", keys: &[], laws: &[] },
    // ── Hooks and output
    FnDoc { section: "Hooks, monitors and output", name: "sim.every", signature: "sim.every(#{ … }, |s| …)", summary: "Call a closure periodically during runs (e.g. `|s| s.write_vtk()`).", keys: EVERY_KEYS, laws: &[] },
    FnDoc { section: "Hooks, monitors and output", name: "sim.monitor", signature: "sim.monitor(name, #{ … }, |s| value) -> Monitor",
        summary: "Record a number during runs; streamed to `<out_dir>/<name>.csv` (the header when the first value is recorded, then each value appended as it is recorded, so an interrupted or killed run keeps its history). `name` names a file (as the simulation's) and is not `energy` or `cracks`. Monitor methods: `last()`, `len()`, `values()`, `times()`, `write_csv()` (makes sure the file exists), and the post-processing below.", keys: MONITOR_KEYS, laws: &[] },
    FnDoc { section: "Hooks, monitors and output", name: "monitor.peak_abs", signature: "monitor.max(), min(), peak(), peak_abs(), argmax(), argmin(), argmax_abs(), at(t), first_crossing(level [, direction]), slope(t0, t1), fit(t0, t1)",
        summary: "A monitor's history, measured: `max()` (= `peak()`) and `min()` the largest and smallest recorded value (0 before anything is recorded), `peak_abs()` the largest |value| (use it for a load whose sign depends on the direction, e.g. a compressive reaction); `argmax()`, `argmin()`, `argmax_abs()` the time [s] of those values (the first on ties); `at(t)` the value at time t, linear between samples (an error outside the recorded times); `first_crossing(level)` the first time the value reaches `level`, linear between the two samples around it, `()` if it never does (`direction` \"up\", \"down\" or \"any\", the default); `slope(t0, t1)` the least-squares slope over the samples with t0 ≤ t ≤ t1 and `fit(t0, t1)` the whole line `#{ slope, intercept, r2, n }` (an error with fewer than 2 samples). Example: `let rate = load.slope(0.0, 0.002);` (the loading rate [N/s] over the first 2 ms), `let t_half = load.first_crossing(0.5 * load.max(), \"up\");`.", keys: &[], laws: &[] },
    FnDoc { section: "Hooks, monitors and output", name: "sim.plot", signature: "sim.plot(#{ … }) -> [paths]",
        summary: "Plot monitors as PNG and SVG in the simulation's output directory, from what they have recorded at the call (call it after a run, or from a hook to follow a long run), with axis labels, units where they are known, a legend and a title; drawn by fdem with its own font (no Python, no system fonts). Returns the paths written (none under `fdem check`). Example: `sim.plot(#{ file: \"load_displacement\", x: \"platen_displacement\", y: [\"platen_force\"], x_label: \"platen displacement [mm]\", y_label: \"force [kN]\" });`. `fdem plot out/DIR` draws the same from the CSV files of a finished run (docs/getting-started.md, Plots).", keys: PLOT_KEYS, laws: &[] },
    FnDoc { section: "Hooks, monitors and output", name: "sim.plot_energy", signature: "sim.plot_energy([#{ … }]) -> [paths]",
        summary: "Plot the energy account recorded so far (the samples of energy.csv) as PNG and SVG in the output directory: every term that is not zero throughout against time [J], and the balance error below it in a panel of its own. Returns the paths written.", keys: PLOT_ENERGY_KEYS, laws: &[] },
    FnDoc { section: "Hooks, monitors and output", name: "sim.checkpoint", signature: "sim.checkpoint()",
        summary: "Write the simulation's whole state to `checkpoint.fdemck` in its output directory (replacing the last one, atomically): positions, velocities, joint, contact, bar and rigid-body state, fracture events, the energy account, monitors, hook clocks and output numbering. Called inside a run (from `sim.every`), it is taken at the end of that step. `fdem run SCRIPT --restart out/<name>/checkpoint.fdemck` runs the script again and continues from it bit for bit, for any thread count (same script, same `--set` values, same fdem). Ctrl-C and SIGTERM write one too. A periodic checkpoint: `sim.every(#{ time: 0.1 }, |s| s.checkpoint());`. See docs/getting-started.md, Stopping and restarting.", keys: &[], laws: &[] },
    FnDoc { section: "Hooks, monitors and output", name: "sim.repartition", signature: "sim.repartition([#{ … }]) -> seconds",
        summary: "On a model run on several MPI ranks (docs/cluster.md): split nodes and work between the ranks again from where the nodes are now, so that bodies and fragments that moved are computed by the rank of their new place. The results are the same bits with or without it. Call it from a hook, on every rank alike: `sim.every(#{ steps: 2000 }, |s| s.repartition());`. With `#{ if_moved: 0.1 }` it splits only when at least a tenth of the nodes would change rank, so a frequent hook costs a small collective until bodies have moved: `sim.every(#{ steps: 200 }, |s| s.repartition(#{ if_moved: 0.1 }));`; with `#{ if_imbalance: 1.15 }` only when the ranks' work since the last call was unbalanced by 15 % or more. Returns the seconds it took (0 on one process, where it does nothing).", keys: REPARTITION_KEYS, laws: &[] },
    FnDoc { section: "Hooks, monitors and output", name: "sim.write_vtk", signature: "sim.write_vtk()",
        summary: "Write a ParaView frame `<name>_NNNNNN.vtu` and update `<name>.pvd`: displacement, velocity (points); Cauchy stress, von Mises, principal stresses, body, material, and with joints `damage` (largest joint damage on the tet's faces) and `fragment` (cells). Once a joint has broken it also writes the crack surface `<name>_cracks_NNNNNN.vtu` + `<name>_cracks.pvd`: one triangle per broken joint with `time` of breaking, `mode` (1 = I, 2 = II, 3 = mixed), `body`, `joint`.", keys: &[], laws: &[] },
    // ── Queries
    FnDoc { section: "Queries", name: "s.time", signature: "s.time, s.step, s.dt, s.n_nodes, s.n_tets", summary: "Simulated time [s], steps done, time step [s], sizes.", keys: &[], laws: &[] },
    FnDoc { section: "Queries", name: "s.kinetic_energy", signature: "s.kinetic_energy(), s.strain_energy()", summary: "Current kinetic and strain energy [J].", keys: &[], laws: &[] },
    FnDoc { section: "Queries", name: "s.energy", signature: "s.energy() -> map", summary: "Energy account at the last sample [J]: kinetic, strain, joint (elastic energy of the joints), external_work, gravity_work, force_work, reaction_work, ground_work (relative-frame ground motion), damping (mass-proportional + viscous), fracture (dissipated by joints: damage, plastic slip and friction of broken joints), contact (recoverable: the penalty energy p∫(φ_c + φ_t) dV and the friction springs), friction (dissipated by contact friction and the contact dashpot), plastic (plastic work of the steel bars and the elastic energy of ruptured ones), bond (recoverable energy of the bar–host bond), bond_slip (dissipated by bond slip), initial, balance_error, relative_error (balance_error over the largest term, or over `floor` when every term is smaller), floor (½·Σ E·V₀·(1e-7)²: the model's elastic energy at a strain of 1e-7, so that a model at rest with energies of roundoff size does not read as unbalanced).", keys: &[], laws: &[] },
    FnDoc { section: "Queries", name: "s.displacement", signature: "s.displacement(nodes) -> [x, y, z]", summary: "Mean displacement of the nodes [m]. Also `s.position(nodes)` [m] and `s.velocity(nodes)` [m/s]. These are plain node means (every node counts once, whatever its mass): right for a face or a loading line; for the centre of mass of a part use `s.mass_position(nodes)` and `s.mass_velocity(nodes)`.", keys: &[], laws: &[] },
    FnDoc { section: "Queries", name: "s.mass_position", signature: "s.mass_position(nodes), s.mass_velocity(nodes) -> [x, y, z]", summary: "Mass-weighted means over the nodes with their lumped masses: their centre of mass now [m] and its velocity at the last half step [m/s] (= momentum / mass). For a whole body the same as `body.center_of_mass()` and `body.velocity()`.", keys: &[], laws: &[] },
    FnDoc { section: "Queries", name: "s.reaction", signature: "s.reaction(nodes) -> [x, y, z]", summary: "Sum of the constraint forces on the nodes in the last step [N]: the force the support or the driver exerts on the body, in global axes. A platen pushing down (−z) into a specimen reads a negative z reaction on the platen nodes, and the base that holds the specimen a positive one: `let f = sim.monitor(\"load\", #{ every: 20 }, |s| -s.reaction(top)[2]);` records compression as positive; `f.peak_abs()` is sign-proof.", keys: &[], laws: &[] },
    FnDoc { section: "Queries", name: "s.mean_stress", signature: "s.mean_stress(elements) -> [[..], [..], [..]]", summary: "Volume-weighted mean Cauchy stress of the elements [Pa]; `s.max_von_mises(elements)` the largest von Mises stress [Pa].", keys: &[], laws: &[] },
];

/// The documentation of a function (`name` as in [`FnDoc::name`]). A name that is not
/// documented is a bug in the binding that asks, so it panics naming it
/// (`tests/api.rs` checks every name the bindings ask for).
pub fn doc_of(name: &str) -> &'static FnDoc {
    API.iter().find(|f| f.name == name).unwrap_or_else(|| {
        panic!("script function '{name}' is not documented in src/script/api.rs")
    })
}

/// The documented keys of a function.
pub fn keys_of(name: &str) -> &'static [Key] {
    doc_of(name).keys
}

/// The keys of `func(law, #{ … })` for one law: the law's own and the function's common
/// ones. An unknown law is an error listing the laws.
pub fn law_keys(func: &str, law: &str) -> Result<Vec<Key>, String> {
    let d = doc_of(func);
    match d.laws.iter().find(|l| l.name == law) {
        Some(l) => Ok(l.params.iter().chain(d.keys).copied().collect()),
        None => {
            let names: Vec<String> = d.laws.iter().map(|l| format!("\"{}\"", l.name)).collect();
            Err(format!(
                "unknown law \"{law}\"; the allowed laws are {}",
                names.join(", ")
            ))
        }
    }
}

/// For a key that `func` does not allow with `law`: the other laws that take it.
pub fn laws_taking(func: &str, key: &str) -> Vec<&'static str> {
    doc_of(func)
        .laws
        .iter()
        .filter(|l| l.params.iter().any(|p| p.name == key))
        .map(|l| l.name)
        .collect()
}

/// The reference as Markdown (what `fdem doc` prints and docs/script-reference.md holds).
pub fn markdown() -> String {
    let mut out = String::from(
        "# Script reference\n\nGenerated by `fdem doc` from `src/script/api.rs`; the same table validates option maps, \
so every key listed here is accepted and every other key is an error that names the allowed ones.\n\n\
Units are SI. Vectors are arrays `[x, y, z]`; integers are accepted where a float is expected.\n",
    );
    for (section, intro) in SECTIONS {
        out.push_str(&format!("\n## {section}\n\n{intro}\n"));
        for f in API.iter().filter(|f| f.section == *section) {
            out.push_str(&format!("\n### `{}`\n\n{}\n", f.signature, f.summary));
            for l in f.laws {
                out.push_str(&format!("\n**`\"{}\"`**: {}\n", l.name, l.summary));
                key_table(&mut out, l.params);
            }
            if !f.keys.is_empty() {
                if !f.laws.is_empty() {
                    out.push_str("\nEvery law also takes:\n");
                }
                key_table(&mut out, f.keys);
            }
        }
    }
    out
}

fn key_table(out: &mut String, keys: &[Key]) {
    out.push_str(
        "\n| key | type | unit | default | range | meaning |\n|---|---|---|---|---|---|\n",
    );
    for k in keys {
        out.push_str(&format!(
            "| `{}` | {} | {} | {} | {} | {} |\n",
            k.name,
            k.kind,
            k.unit,
            k.default_text(),
            k.range.text(),
            k.doc
        ));
    }
}
