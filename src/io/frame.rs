//! Build one ParaView frame of a simulation: point and cell fields in VTK layout.

use super::vtu::{encode_vtu_with, DataArray, Encoding, Field, VtuFrame};

use crate::elements::deformation_gradient;
use crate::material::StressMeasure;
use crate::math::von_mises;
use crate::pipeline::Simulation;
use rayon::prelude::*;

/// Encode the current state as `.vtu` bytes: points at the current positions; point data
/// `displacement` [m] and `velocity` [m/s] (half-step); cell data `stress` (Cauchy, 9
/// components, Pa), `von_mises` [Pa], `principal_stress` (σ1 ≥ σ2 ≥ σ3, Pa), `body`, `material`, and `stress_pk1`/`stress_pk2` when
/// `extra` asks for it. With joints: cell data `damage` and `fragment`; with contact: point
/// data `contact_force` [N] and cell data `contact_pressure` [Pa] (the largest mean pressure
/// |F_n|/A over the element's touching pairs) of the last step.
pub fn encode_frame(
    sim: &Simulation,
    extra: StressMeasure,
    encoding: Encoding,
) -> Result<Vec<u8>, String> {
    let n = &sim.nodes;
    let points: Vec<[f64; 3]> = n.x.iter().map(|p| [p.x, p.y, p.z]).collect();
    let disp: Vec<[f64; 3]> =
        n.x.iter()
            .zip(&n.x0)
            .map(|(x, x0)| [x.x - x0.x, x.y - x0.y, x.z - x0.z])
            .collect();
    let vel: Vec<[f64; 3]> = n.v.iter().map(|v| [v.x, v.y, v.z]).collect();
    let stress_of = |measure: StressMeasure| -> Vec<[f64; 9]> {
        (0..sim.tets.len())
            .into_par_iter()
            .map(|e| {
                let f = deformation_gradient(&sim.tets, &n.x, e);
                let s = sim.materials[sim.tets.material[e] as usize].stress(&f, measure);
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
    };
    let cauchy = stress_of(StressMeasure::Cauchy);
    // Principal stresses σ1 ≥ σ2 ≥ σ3 (eigenvalues of the symmetric Cauchy stress).
    let principal: Vec<[f64; 3]> = cauchy
        .par_iter()
        .map(|s| {
            let mut e: [f64; 3] = crate::math::Mat3::from_row_slice(s)
                .symmetric_eigenvalues()
                .into();
            e.sort_by(|a, b| b.total_cmp(a));
            e
        })
        .collect();
    let vm: Vec<f64> = cauchy
        .iter()
        .map(|s| von_mises(&crate::math::Mat3::from_row_slice(s)))
        .collect();
    let body: Vec<i32> = sim.tets.body.iter().map(|&b| b as i32).collect();
    let material: Vec<i32> = sim.tets.material.iter().map(|&m| m as i32).collect();
    let extra_stress = (extra != StressMeasure::Cauchy).then(|| stress_of(extra));
    // With joints: the largest damage over each tet's joints, and the fragment id.
    let (damage, fragment): (Vec<f64>, Vec<i32>) = if sim.joints.is_empty() {
        (Vec::new(), Vec::new())
    } else {
        let mut d = vec![0.0f64; sim.tets.len()];
        for (j, tets) in sim.joints.tets.iter().enumerate() {
            let dj = sim.joints.state[j]
                .iter()
                .map(|p| p.damage)
                .fold(0.0, f64::max);
            for &t in tets {
                d[t as usize] = d[t as usize].max(dj);
            }
        }
        let frag = crate::fracture::fragments(&sim.tets.nodes, &sim.joints, sim.nodes.len());
        (d, frag.into_iter().map(|f| f as i32).collect())
    };
    let extra_name = format!("stress_{}", extra.name());
    let mut cell_data = vec![
        Field {
            name: "stress",
            data: DataArray::TensorF64(&cauchy),
        },
        Field {
            name: "von_mises",
            data: DataArray::ScalarF64(&vm),
        },
        Field {
            name: "principal_stress",
            data: DataArray::VectorF64(&principal),
        },
        Field {
            name: "body",
            data: DataArray::ScalarI32(&body),
        },
        Field {
            name: "material",
            data: DataArray::ScalarI32(&material),
        },
    ];
    if !damage.is_empty() {
        cell_data.push(Field {
            name: "damage",
            data: DataArray::ScalarF64(&damage),
        });
        cell_data.push(Field {
            name: "fragment",
            data: DataArray::ScalarI32(&fragment),
        });
    }
    let contact_on = sim.contact.is_enabled();
    let contact_pressure = if contact_on {
        sim.contact.tet_pressures(sim.tets.len())
    } else {
        Vec::new()
    };
    if contact_on {
        cell_data.push(Field {
            name: "contact_pressure",
            data: DataArray::ScalarF64(&contact_pressure),
        });
    }
    let contact_force: Vec<[f64; 3]> = if contact_on {
        sim.contact
            .node_forces(sim.nodes.len())
            .iter()
            .map(|f| [f.x, f.y, f.z])
            .collect()
    } else {
        Vec::new()
    };
    if let Some(s) = &extra_stress {
        cell_data.push(Field {
            name: &extra_name,
            data: DataArray::TensorF64(s),
        });
    }
    let frame = VtuFrame {
        points: &points,
        tets: &sim.tets.nodes,
        triangles: &[],
        point_data: vec![
            Field {
                name: "displacement",
                data: DataArray::VectorF64(&disp),
            },
            Field {
                name: "velocity",
                data: DataArray::VectorF64(&vel),
            },
        ],
        cell_data,
    };
    let mut frame = frame;
    if contact_on {
        frame.point_data.push(Field {
            name: "contact_force",
            data: DataArray::VectorF64(&contact_force),
        });
    }
    encode_vtu_with(&frame, encoding)
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
        points: &points,
        tets: &[],
        triangles: &triangles,
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
