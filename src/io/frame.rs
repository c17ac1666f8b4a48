//! Build one ParaView frame of a simulation: point and cell fields in VTK layout.

use super::vtu::{encode_pvtu, encode_vtu_with, DataArray, Encoding, Field, VtuFrame};

use crate::material::StressMeasure;
use crate::math::von_mises;
use crate::pipeline::{FrameReads, Simulation};
use rayon::prelude::*;

/// Encode the current state as `.vtu` bytes: points at the current positions; point data
/// `displacement` [m] and `velocity` [m/s] (half-step); cell data `stress` (Cauchy, 9
/// components, Pa), `von_mises` [Pa], `principal_stress` (σ1 ≥ σ2 ≥ σ3, Pa), `body`, `material`, and `stress_pk1`/`stress_pk2` when
/// `extra` asks for it. With joints: cell data `damage` and `fragment`; with contact: point
/// data `contact_force` [N] and cell data `contact_pressure` [Pa] (the largest mean pressure
/// |F_n|/A over the element's touching pairs) of the last step. Joint damage and contact
/// come from `reads` ([`FrameReads::of`] the simulation, or what a decomposed model's rank
/// 0 gathered: `Simulation::gather_frame_to_root`).
pub fn encode_frame(
    sim: &Simulation,
    reads: &FrameReads,
    extra: StressMeasure,
    encoding: Encoding,
) -> Result<Vec<u8>, String> {
    let all = |n: usize| (0..n as u32).collect::<Vec<u32>>();
    let (tets, nodes) = (all(sim.tets.len()), all(sim.nodes.len()));
    let data = FrameData::of(sim, reads, extra, &tets, &nodes);
    let extra_name = format!("stress_{}", extra.name());
    let frame = VtuFrame {
        points: data.points(),
        tets: &sim.tets.nodes,
        triangles: &[],
        lines: &[],
        point_data: data.point_fields(),
        cell_data: data.cell_fields(&extra_name),
    };
    encode_vtu_with(&frame, encoding)
}

/// One piece of a frame written in pieces (`vtk_pieces: "per_rank"`): the tets `keep`
/// selects (in tet order) and the nodes they use (in node order, renumbered), with every
/// array of [`encode_frame`] and two more, `tet_id` (cell data) and `node_id` (point data):
/// the global tet and node ids, so the pieces can be put back together. Returns the piece's
/// `.vtu` bytes and, built from its layout, the `.pvtu` that names `sources` as the pieces.
pub fn encode_frame_piece(
    sim: &Simulation,
    reads: &FrameReads,
    extra: StressMeasure,
    encoding: Encoding,
    keep: impl Fn(usize) -> bool,
    sources: &[String],
) -> Result<(Vec<u8>, Vec<u8>), String> {
    let tets: Vec<u32> = (0..sim.tets.len())
        .filter(|&e| keep(e))
        .map(|e| e as u32)
        .collect();
    let mut local = vec![u32::MAX; sim.nodes.len()];
    for &e in &tets {
        for n in sim.tets.nodes[e as usize] {
            local[n as usize] = 0;
        }
    }
    let mut nodes: Vec<u32> = Vec::new();
    for (n, l) in local.iter_mut().enumerate() {
        if *l == 0 {
            *l = nodes.len() as u32;
            nodes.push(n as u32);
        }
    }
    let piece = FrameData::of(sim, reads, extra, &tets, &nodes);
    let cells: Vec<[u32; 4]> = tets
        .iter()
        .map(|&e| sim.tets.nodes[e as usize].map(|n| local[n as usize]))
        .collect();
    let tet_id: Vec<i32> = tets.iter().map(|&e| e as i32).collect();
    let node_id: Vec<i32> = nodes.iter().map(|&n| n as i32).collect();
    let extra_name = format!("stress_{}", extra.name());
    let mut point_data = piece.point_fields();
    point_data.push(Field {
        name: "node_id",
        data: DataArray::ScalarI32(&node_id),
    });
    let mut cell_data = piece.cell_fields(&extra_name);
    cell_data.push(Field {
        name: "tet_id",
        data: DataArray::ScalarI32(&tet_id),
    });
    let frame = VtuFrame {
        points: piece.points(),
        tets: &cells,
        triangles: &[],
        lines: &[],
        point_data,
        cell_data,
    };
    Ok((
        encode_vtu_with(&frame, encoding)?,
        encode_pvtu(&frame, sources),
    ))
}

/// Values computed as the frame's bytes are written ([`DataArray::VectorF64Of`]).
type Gather<'s, T> = Box<dyn Fn(usize) -> T + 's>;

/// The fields of one frame of [`encode_frame`], lent to the [`VtuFrame`]. The stresses are
/// computed here (in parallel, the principal stresses and von Mises from the Cauchy stress);
/// the nodes' fields (positions, displacements, velocities, contact forces) and the tets'
/// ids, damage, fragment and contact pressure are gathered from the model's arrays as they
/// are written, so a frame holds no copy of them beside its bytes (on the 61 440-tet bar
/// 17.7 MB less at the frame's peak; docs/performance.md).
struct FrameData<'s> {
    n_points: usize,
    n_cells: usize,
    /// Current node positions [m].
    points: Gather<'s, [f64; 3]>,
    /// Node displacements from the reference positions [m].
    displacement: Gather<'s, [f64; 3]>,
    /// Node velocities (half-step) [m/s].
    velocity: Gather<'s, [f64; 3]>,
    /// Cauchy stress per tetrahedron, 9 components row-major [Pa].
    cauchy: Vec<[f64; 9]>,
    /// Principal stresses σ1 ≥ σ2 ≥ σ3 per tetrahedron [Pa].
    principal: Vec<[f64; 3]>,
    /// Von Mises stress per tetrahedron [Pa].
    von_mises: Vec<f64>,
    /// Body id per tetrahedron.
    body: Gather<'s, i32>,
    /// Material id per tetrahedron.
    material: Gather<'s, i32>,
    /// The `extra` stress measure per tetrahedron [Pa], unless it is Cauchy.
    extra_stress: Option<Vec<[f64; 9]>>,
    /// Largest joint damage and fragment id per tetrahedron (None without joints).
    joints: Option<(Gather<'s, f64>, Gather<'s, i32>)>,
    /// With contact: the largest mean contact pressure per tetrahedron [Pa] and the contact
    /// force per node [N] over the last step.
    contact: Option<(Gather<'s, f64>, Gather<'s, [f64; 3]>)>,
}

impl<'s> FrameData<'s> {
    /// The fields of the tets `tets` and the nodes `nodes` (both by global id, in file
    /// order) from the current state of `sim` and `reads`. Only those are computed: a piece
    /// of a frame costs its own tets.
    fn of(
        sim: &'s Simulation,
        reads: &'s FrameReads,
        extra: StressMeasure,
        tets: &'s [u32],
        nodes: &'s [u32],
    ) -> Self {
        let n = &sim.nodes;
        let cauchy = stresses(sim, tets, StressMeasure::Cauchy);
        let principal = principal_stresses(&cauchy);
        let von_mises: Vec<f64> = cauchy
            .iter()
            .map(|s| von_mises(&crate::math::Mat3::from_row_slice(s)))
            .collect();
        let extra_stress = (extra != StressMeasure::Cauchy).then(|| stresses(sim, tets, extra));
        let joints = joint_fields(sim, &reads.joint_damage).map(|(damage, fragment)| {
            let damage: Gather<f64> = Box::new(move |i| damage[tets[i] as usize]);
            let fragment: Gather<i32> = Box::new(move |i| fragment[tets[i] as usize]);
            (damage, fragment)
        });
        let contact = sim.contact.is_enabled().then(|| {
            let (pressure, force) = (&reads.contact_pressure, &reads.contact_force);
            let pressure: Gather<f64> = Box::new(move |i| pressure[tets[i] as usize]);
            let force: Gather<[f64; 3]> = Box::new(move |i| force[nodes[i] as usize].into());
            (pressure, force)
        });
        FrameData {
            n_points: nodes.len(),
            n_cells: tets.len(),
            points: Box::new(move |i| n.x[nodes[i] as usize].into()),
            displacement: Box::new(move |i| {
                let k = nodes[i] as usize;
                (n.x[k] - n.x0[k]).into()
            }),
            velocity: Box::new(move |i| n.v[nodes[i] as usize].into()),
            cauchy,
            principal,
            von_mises,
            body: Box::new(move |i| sim.tets.body[tets[i] as usize] as i32),
            material: Box::new(move |i| sim.tets.material[tets[i] as usize] as i32),
            extra_stress,
            joints,
            contact,
        }
    }

    /// The node positions.
    fn points(&self) -> DataArray<'_> {
        DataArray::VectorF64Of(self.n_points, &*self.points)
    }

    /// Point data: `displacement`, `velocity` and, with contact, `contact_force`.
    fn point_fields(&self) -> Vec<Field<'_>> {
        let mut fields = vec![
            Field {
                name: "displacement",
                data: DataArray::VectorF64Of(self.n_points, &*self.displacement),
            },
            Field {
                name: "velocity",
                data: DataArray::VectorF64Of(self.n_points, &*self.velocity),
            },
        ];
        if let Some((_, force)) = &self.contact {
            fields.push(Field {
                name: "contact_force",
                data: DataArray::VectorF64Of(self.n_points, &**force),
            });
        }
        fields
    }

    /// Cell data in file order; the extra stress, if any, is named `extra_name`.
    fn cell_fields<'a>(&'a self, extra_name: &'a str) -> Vec<Field<'a>> {
        let mut fields = vec![
            Field {
                name: "stress",
                data: DataArray::TensorF64(&self.cauchy),
            },
            Field {
                name: "von_mises",
                data: DataArray::ScalarF64(&self.von_mises),
            },
            Field {
                name: "principal_stress",
                data: DataArray::VectorF64(&self.principal),
            },
            Field {
                name: "body",
                data: DataArray::ScalarI32Of(self.n_cells, &*self.body),
            },
            Field {
                name: "material",
                data: DataArray::ScalarI32Of(self.n_cells, &*self.material),
            },
        ];
        if let Some((damage, fragment)) = &self.joints {
            fields.push(Field {
                name: "damage",
                data: DataArray::ScalarF64Of(self.n_cells, &**damage),
            });
            fields.push(Field {
                name: "fragment",
                data: DataArray::ScalarI32Of(self.n_cells, &**fragment),
            });
        }
        if let Some((pressure, _)) = &self.contact {
            fields.push(Field {
                name: "contact_pressure",
                data: DataArray::ScalarF64Of(self.n_cells, &**pressure),
            });
        }
        if let Some(s) = &self.extra_stress {
            fields.push(Field {
                name: extra_name,
                data: DataArray::TensorF64(s),
            });
        }
        fields
    }
}

/// Stress of the tetrahedra `tets` in the given measure, 9 components row-major [Pa].
fn stresses(sim: &Simulation, tets: &[u32], measure: StressMeasure) -> Vec<[f64; 9]> {
    tets.par_iter()
        .map(|&e| {
            let s = sim.stress(e as usize, measure);
            [
                s[(0, 0)],
                s[(0, 1)],
                s[(0, 2)],
                s[(1, 0)],
                s[(1, 1)],
                s[(1, 2)],
                s[(2, 0)],
                s[(2, 1)],
                s[(2, 2)],
            ]
        })
        .collect()
}

/// Principal stresses σ1 ≥ σ2 ≥ σ3 [Pa] (eigenvalues of each symmetric Cauchy stress).
fn principal_stresses(cauchy: &[[f64; 9]]) -> Vec<[f64; 3]> {
    cauchy
        .par_iter()
        .map(|s| {
            let mut e: [f64; 3] = crate::math::Mat3::from_row_slice(s)
                .symmetric_eigenvalues()
                .into();
            e.sort_by(|a, b| b.total_cmp(a));
            e
        })
        .collect()
}

/// Per tet: the largest damage of its joints and its fragment id (None without joints).
fn joint_fields(sim: &Simulation, joint_damage: &[f64]) -> Option<(Vec<f64>, Vec<i32>)> {
    if sim.joints.is_empty() {
        return None;
    }
    let mut d = vec![0.0f64; sim.tets.len()];
    for (tets, &dj) in sim.joints.tets.iter().zip(joint_damage) {
        for &t in tets {
            d[t as usize] = d[t as usize].max(dj);
        }
    }
    let frag = crate::fracture::fragments(&sim.tets.nodes, &sim.joints, sim.nodes.len());
    Some((d, frag.into_iter().map(|f| f as i32).collect()))
}

/// Encode the crack surface as `.vtu` bytes: one triangle per broken joint (face A at its
/// current position), with cell data `time` of breaking [s], `mode` (1 = I, 2 = II, 3 = mixed),
/// `body` and `joint`. An empty surface (no joint broken yet) is a valid frame without cells.
pub fn encode_cracks(sim: &Simulation, encoding: Encoding) -> Result<Vec<u8>, String> {
    let n = sim.break_events.len();
    let mut points = Vec::with_capacity(3 * n);
    let mut triangles = Vec::with_capacity(n);
    let (mut time, mut mode, mut body, mut joint) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    for e in &sim.break_events {
        let base = points.len() as u32;
        for &node in &sim.joints.faces[e.joint][0] {
            let p = sim.nodes.x[node as usize];
            points.push([p.x, p.y, p.z]);
        }
        triangles.push([base, base + 1, base + 2]);
        time.push(e.time);
        mode.push(e.mode.code());
        body.push(e.body as i32);
        joint.push(e.joint as i32);
    }
    let frame = VtuFrame {
        points: DataArray::VectorF64(&points),
        tets: &[],
        triangles: &triangles,
        lines: &[],
        point_data: Vec::new(),
        cell_data: vec![
            Field {
                name: "time",
                data: DataArray::ScalarF64(&time),
            },
            Field {
                name: "mode",
                data: DataArray::ScalarI32(&mode),
            },
            Field {
                name: "body",
                data: DataArray::ScalarI32(&body),
            },
            Field {
                name: "joint",
                data: DataArray::ScalarI32(&joint),
            },
        ],
    };
    encode_vtu_with(&frame, encoding)
}

/// Encode the bars of every rebar as `.vtu` bytes: one line cell per bar at its current
/// position, with cell data `axial_force` [N], `stress` [Pa], `strain`, `plastic_strain`,
/// `rebar` (index) and `ruptured` (1 once broken), and point data `slip` [m] and
/// `bond_stress` [Pa] of the bond point at each bar node and `bending_moment` [N·m] of the
/// hinge there (0 at a bar's ends).
pub fn encode_bars(sim: &Simulation, encoding: Encoding) -> Result<Vec<u8>, String> {
    let bars = &sim.bars;
    let first = sim.rebars.first().map_or(0, |r| r.nodes.start);
    let points: Vec<[f64; 3]> = sim.nodes.x[first..]
        .iter()
        .map(|p| [p.x, p.y, p.z])
        .collect();
    // Bar nodes of all rebars are one contiguous range after the bodies' nodes, unless a
    // body was added after a rebar: then its nodes sit in the range too, used by no line.
    let lines: Vec<[u32; 2]> = bars
        .nodes
        .iter()
        .map(|n| n.map(|i| i - first as u32))
        .collect();
    let force: Vec<f64> = (0..bars.len()).map(|b| bars.axial_force(b)).collect();
    let rebar: Vec<i32> = bars.rebar.iter().map(|&r| r as i32).collect();
    let ruptured: Vec<i32> = bars
        .ruptured_at
        .iter()
        .map(|t| !t.is_nan() as i32)
        .collect();
    let mut slip = vec![0.0; points.len()];
    let mut bond_stress = vec![0.0; points.len()];
    for p in 0..sim.bonds.len() {
        let i = sim.bonds.node[p] as usize - first;
        slip[i] = sim.bonds.slip[p];
        bond_stress[i] = sim.bonds.stress[p];
    }
    let mut moment = vec![0.0; points.len()];
    for (h, n) in bars.hinges.nodes.iter().enumerate() {
        moment[n[1] as usize - first] = bars.hinges.moment[h];
    }
    let frame = VtuFrame {
        points: DataArray::VectorF64(&points),
        tets: &[],
        triangles: &[],
        lines: &lines,
        point_data: vec![
            Field {
                name: "slip",
                data: DataArray::ScalarF64(&slip),
            },
            Field {
                name: "bond_stress",
                data: DataArray::ScalarF64(&bond_stress),
            },
            Field {
                name: "bending_moment",
                data: DataArray::ScalarF64(&moment),
            },
        ],
        cell_data: vec![
            Field {
                name: "axial_force",
                data: DataArray::ScalarF64(&force),
            },
            Field {
                name: "stress",
                data: DataArray::ScalarF64(&bars.stress),
            },
            Field {
                name: "strain",
                data: DataArray::ScalarF64(&bars.strain),
            },
            Field {
                name: "plastic_strain",
                data: DataArray::ScalarF64(&bars.plastic_strain),
            },
            Field {
                name: "rebar",
                data: DataArray::ScalarI32(&rebar),
            },
            Field {
                name: "ruptured",
                data: DataArray::ScalarI32(&ruptured),
            },
        ],
    };
    encode_vtu_with(&frame, encoding)
}
