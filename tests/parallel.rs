//! A model decomposed over N ranks reproduces the one-rank run bit for bit (issue 17,
//! crate::parallel): positions, velocities, joint histories, break events and the energy
//! account, for N = 2, 3, 4. The ranks are threads of this process ([`ThreadComm`]): the same
//! split and the same exchanges as under MPI, without an MPI installation.
//!
//! Reference: the one-rank run of the same model. Tolerance: none (exact equality), because
//! the decomposition is built to add every node's contributions, and every sum's unit
//! partials, in the one-rank order.

use fdem::joints::law::{Calibration, Cohesive, Softening};
use fdem::joints::JointLaw;
use fdem::loads::{PrescribedVelocity, TimeFunction};
use fdem::material::{Formulation, Material};
use fdem::math::{Real, Vec3};
use fdem::mesh::{box_mesh, Region};
use fdem::parallel::ThreadComm;
use fdem::pipeline::EnergySample;
use fdem::{Layout, Simulation};

/// Everything a run leaves that must not depend on the number of ranks.
#[derive(Debug, PartialEq)]
struct Outcome {
    x: Vec<Vec3>,
    v: Vec<Vec3>,
    /// The constrained nodes and their reactions.
    reaction: Vec<(u32, Vec3)>,
    damage: Vec<Real>,
    broken: Vec<bool>,
    events: Vec<fdem::fracture::BreakEvent>,
    energy: Vec<EnergySample>,
    contact_events: Vec<fdem::contact_interaction::ContactEvent>,
    pairs: Vec<fdem::contact_interaction::PairState>,
    handed_over: Vec<bool>,
    /// Each rigid body's centre, velocity, angular momentum and force.
    rigid: Vec<[Vec3; 4]>,
    /// The bars' stress and plastic strain, the bond points' slip, largest slip and
    /// dissipated energy, one after the other.
    rebars: Vec<Real>,
}

fn outcome(sim: &Simulation) -> Outcome {
    Outcome {
        x: sim.nodes.x.clone(),
        v: sim.nodes.v.clone(),
        reaction: (sim.nodes.constrained.node.iter().copied())
            .zip(sim.nodes.constrained.reaction.iter().copied())
            .collect(),
        damage: sim
            .joints
            .state
            .iter()
            .flat_map(|s| s.iter().map(|p| p.damage))
            .collect(),
        broken: sim.joints.broken.clone(),
        events: sim.break_events.clone(),
        energy: sim.energy_history.clone(),
        contact_events: sim.contact.events.clone(),
        pairs: sim.contact.pair_states().collect(),
        handed_over: sim.joints.handed_over.clone(),
        rigid: (sim.rigid.bodies.iter())
            .map(|w| [w.center, w.velocity, w.angular_momentum, w.force])
            .collect(),
        rebars: (sim.bars.stress.iter())
            .chain(&sim.bars.plastic_strain)
            .chain(&sim.bonds.slip)
            .chain(&sim.bonds.max_slip)
            .chain(&sim.bonds.dissipated)
            .copied()
            .collect(),
    }
}

/// Every node a rank does not keep current is NaN between synchronizations (as with
/// `FDEM_CHECK_HALO=1`): what a rank reads outside its halo while stepping would show.
fn check_halo() {
    fdem::parallel::check_halo(true);
}

/// Run `build()` for `steps` steps on one rank and on 2, 3, 4; every rank of every count
/// must end with the one-rank outcome, joint histories included once the ranks have
/// synchronised (while stepping a rank keeps current only the joints it computes).
fn same_on_any_rank_count(build: impl Fn() -> Simulation + Sync, steps: usize) -> Outcome {
    let reference = {
        let mut sim = build();
        for _ in 0..steps {
            sim.step().unwrap();
        }
        outcome(&sim)
    };
    for ranks in 2..=4 {
        check_halo();
        let runs = ThreadComm::run(ranks, |comm| {
            let mut sim = build();
            sim.decompose(comm);
            for step in 0..steps {
                sim.step().unwrap();
                // The whole model's state shared now and then, as output does; the next
                // step's ranks take back their own pairs.
                if step % 97 == 40 {
                    sim.synchronize();
                }
            }
            // Each rank holds only the candidate pairs it computes, and the histories of the
            // joints of its units.
            let cd = &sim.contact_detection;
            let pairs = (cd.pairs.len(), cd.candidate_pairs());
            let joints = sim.joints.state.held();
            sim.synchronize();
            let (rank, size) = sim.rank_and_size();
            assert_eq!(size, ranks);
            (rank, outcome(&sim), pairs, joints)
        });
        let held: usize = runs.iter().map(|r| r.2 .0).sum();
        let each: Vec<usize> = runs.iter().map(|r| r.2 .0).collect();
        let joints_each: Vec<usize> = runs.iter().map(|r| r.3).collect();
        let n_joints = reference.broken.len();
        println!(
            "{ranks} ranks hold {each:?} of {} pairs, the histories of {joints_each:?} of {n_joints} joints",
            reference.pairs.len()
        );
        // Every joint's history is held by some rank, and with more than two units' worth
        // of joints (512 each) no rank holds them all.
        assert!(joints_each.iter().sum::<usize>() >= n_joints);
        if n_joints > 2 * 512 {
            assert!(
                joints_each.iter().all(|&h| h < n_joints),
                "{ranks} ranks hold the histories of {joints_each:?} of {n_joints} joints"
            );
        }
        for (rank, o, (mine, all), _) in runs {
            let place = format!("rank {rank} of {ranks}");
            assert_eq!(
                all,
                reference.pairs.len(),
                "{place}: the count of all pairs"
            );
            assert!(mine <= all, "{place}: holds {mine} of {all} pairs");
            if all > 100 {
                assert!(mine < all, "{place}: holds every pair ({all})");
            }
            assert!(o.x == reference.x, "{place}: positions differ");
            assert!(o.v == reference.v, "{place}: velocities differ");
            assert!(
                o.reaction == reference.reaction,
                "{place}: reactions differ"
            );
            assert_eq!(o.broken, reference.broken, "{place}: broken joints differ");
            assert_eq!(o.events, reference.events, "{place}: break events differ");
            assert_eq!(
                o.energy, reference.energy,
                "{place}: energy account differs"
            );
            assert!(
                o.damage == reference.damage,
                "{place}: joint damage differs"
            );
            assert!(
                o.contact_events == reference.contact_events,
                "{place}: contact events differ"
            );
            assert!(
                o.pairs == reference.pairs,
                "{place}: contact histories differ"
            );
            assert_eq!(
                o.handed_over, reference.handed_over,
                "{place}: joints handed over to contact differ"
            );
            assert!(o.rigid == reference.rigid, "{place}: rigid bodies differ");
            assert!(held >= all, "{ranks} ranks hold {held} of {all} pairs");
            assert!(
                o.rebars == reference.rebars,
                "{place}: bars or bond points differ"
            );
        }
    }
    reference
}

/// The cohesive joint law of the jointed models: tensile strength `ft`, cohesion 3·ft,
/// friction angle 30°, G_II = 4·G_I, penalties 10·E.
fn cohesive(e: Real, ft: Real, g_i: Real, dilatancy: fdem::joints::law::Dilatancy) -> Cohesive {
    Cohesive {
        softening: Softening::Munjiza,
        calibration: Calibration::Exact,
        tensile_strength: ft,
        cohesion: 3.0 * ft,
        tan_friction: 30f64.to_radians().tan(),
        g_i,
        g_ii: 4.0 * g_i,
        normal_penalty: 10.0 * e,
        tangential_penalty: 10.0 * e,
        residual_friction: 0.5,
        rate: fdem::joints::law::RateEffects::None,
        dilatancy,
    }
}

/// A jointed bar, 1 × 0.1 × 0.1 m in 48 × 4 × 4 Kuhn cells (4 608 tets, 18 432 nodes: 9
/// of stage 7's chunks), held at x = 0 and pulled at x = L until it breaks.
fn pulled_jointed_bar() -> Simulation {
    let (l, a, e, rho, ft) = (1.0, 0.1, 1e10, 2500.0, 1e6);
    let mut sim = Simulation::new();
    let m = sim.add_material(Material::new(Formulation::Munjiza, rho, e, 0.2, 0.0).unwrap());
    sim.add_body(
        "bar",
        &box_mesh(Vec3::zeros(), Vec3::new(l, a, a), [48, 4, 4]),
        m,
        Layout::Jointed,
    )
    .unwrap();
    let law = cohesive(e, ft, 50.0, fdem::joints::law::Dilatancy::NONE);
    let id = sim.joints.add_law(JointLaw::Cohesive(law));
    let (body, tets, x0) = (
        sim.bodies[0].clone(),
        sim.tets.nodes.clone(),
        sim.nodes.x0.clone(),
    );
    sim.joints
        .insert_in_body(&body, &tets, &x0, id, |_| true)
        .unwrap();
    let plane = |x: Real, out: Real| {
        sim.nodes_in(
            &Region::HalfSpace {
                point: Vec3::new(x, 0.0, 0.0),
                normal: Vec3::new(out, 0.0, 0.0),
            },
            None,
        )
    };
    let (left, right) = (plane(0.0, -1.0), plane(l, 1.0));
    let c = (e / rho).sqrt();
    // Fast enough to break within a few wave transits: 4 × the strain of f_t in 4 L/c.
    let v = 4.0 * ft / e * l / (4.0 * l / c);
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: left,
        components: [Some(TimeFunction::Constant(0.0)), None, None],
    });
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: right,
        components: [
            Some(TimeFunction::table(vec![(0.0, 0.0), (l / c, v)]).unwrap()),
            None,
            None,
        ],
    });
    sim.settings.energy_every = 7;
    sim
}

/// Stages 1 to 3 and 7 with fracture: the bar breaks, and 2, 3 and 4 ranks give the one-rank
/// run's bits. (Reference: the one-rank run; the check that it breaks keeps the test from
/// passing on a model where nothing happens.)
#[test]
fn jointed_bar_breaks_identically_on_any_rank_count() {
    let reference = same_on_any_rank_count(pulled_jointed_bar, 2000);
    assert!(
        reference.events.len() >= 32,
        "the bar must break through a section, 32 joints of 4 × 4 cells ({} events)",
        reference.events.len()
    );
}

/// Continuous (node-sharing) bodies, one large (its chunks in parallel) and twenty small
/// (grouped into runs), under gravity with mass damping, one face held: forces gathered
/// through the slot buffers, and tets whose nodes two ranks own.
fn continuous_bodies() -> Simulation {
    let mut sim = Simulation::new();
    let m =
        sim.add_material(Material::new(Formulation::NeoHookean, 2000.0, 1e7, 0.3, 1e-3).unwrap());
    sim.add_body(
        "beam",
        &box_mesh(Vec3::zeros(), Vec3::new(2.0, 0.2, 0.2), [60, 6, 6]),
        m,
        Layout::Continuous,
    )
    .unwrap();
    for k in 0..20 {
        let x = 3.0 + 0.5 * k as Real;
        sim.add_body(
            &format!("block{k}"),
            &box_mesh(
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 0.3, 0.3, 0.3),
                [4, 4, 4],
            ),
            m,
            Layout::Continuous,
        )
        .unwrap();
    }
    let held = sim.nodes_in(
        &Region::HalfSpace {
            point: Vec3::zeros(),
            normal: Vec3::new(-1.0, 0.0, 0.0),
        },
        None,
    );
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: held,
        components: [(); 3].map(|_| Some(TimeFunction::Constant(0.0))),
    });
    sim.loads.gravity = Vec3::new(0.0, 0.0, -9.81);
    sim.settings.mass_damping = 5.0;
    sim.settings.energy_every = 3;
    sim
}

#[test]
fn continuous_bodies_move_identically_on_any_rank_count() {
    let reference = same_on_any_rank_count(continuous_bodies, 300);
    let lowest = reference.x.iter().map(|x| x.z).fold(Real::MAX, Real::min);
    assert!(
        lowest < -1e-4,
        "the beam must sag under gravity (lowest z {lowest})"
    );
}

/// A jointed bar (24 × 4 × 4 Kuhn cells, 2 304 tets, dilatant cohesive joints) thrown at 5 m/s down
/// and 1.5 m/s along onto a slab (continuous, 24 × 8 × 2 cells, base held) with Coulomb
/// friction μ = 0.5 and normal damping: the impact (about ρcv = 25 MPa against f_t = 1 MPa)
/// breaks joints, whose faces contact takes over; pairs stick and slide. 9 891 nodes: 5 of
/// stage 7's chunks, so 4 ranks each own some, and contact pairs join nodes of different
/// ranks.
fn bar_thrown_on_a_slab() -> Simulation {
    let (e, rho, ft) = (1e10, 2500.0, 1e6);
    let mut sim = Simulation::new();
    let m = sim.add_material(Material::new(Formulation::Munjiza, rho, e, 0.2, 0.0).unwrap());
    sim.add_body(
        "slab",
        &box_mesh(
            Vec3::new(-0.1, -0.2, -0.1),
            Vec3::new(1.1, 0.2, 0.0),
            [24, 8, 2],
        ),
        m,
        Layout::Continuous,
    )
    .unwrap();
    sim.add_body(
        "bar",
        &box_mesh(
            Vec3::new(0.0, -0.05, 0.001),
            Vec3::new(1.0, 0.05, 0.101),
            [24, 4, 4],
        ),
        m,
        Layout::Jointed,
    )
    .unwrap();
    // Dilatant: a broken joint holds its faces while within the asperities' reach,
    // and contact pairs of its two tets read that.
    let dilatant = fdem::joints::law::Dilatancy {
        tan_angle: 0.2,
        max_opening: 5e-6,
    };
    let law = cohesive(e, ft, 20.0, dilatant);
    let id = sim.joints.add_law(JointLaw::Cohesive(law));
    let (body, tets, x0) = (
        sim.bodies[1].clone(),
        sim.tets.nodes.clone(),
        sim.nodes.x0.clone(),
    );
    sim.joints
        .insert_in_body(&body, &tets, &x0, id, |_| true)
        .unwrap();
    let base = sim.nodes_in(
        &Region::HalfSpace {
            point: Vec3::new(0.0, 0.0, -0.1),
            normal: Vec3::new(0.0, 0.0, -1.0),
        },
        None,
    );
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: base,
        components: [(); 3].map(|_| Some(TimeFunction::Constant(0.0))),
    });
    sim.contact
        .laws
        .rules
        .push(fdem::contact_interaction::ContactRule::from(
            fdem::contact_interaction::PotentialContact {
                friction: 0.5,
                damping: 0.1,
                ..Default::default()
            },
        ));
    sim.contact.record_events = true;
    for n in sim.bodies[1].nodes.clone() {
        sim.nodes.v[n] = Vec3::new(1.5, 0.0, -5.0);
    }
    sim.loads.gravity = Vec3::new(0.0, 0.0, -9.81);
    sim.settings.energy_every = 5;
    sim
}

/// Stages 4 and 5 with fracture: the thrown bar hits the slab, breaks, and its pieces touch
/// the slab and each other; 2, 3 and 4 ranks give the one-rank run's bits, contact histories
/// and events included. (Reference: the one-rank run; the checks below keep the test from
/// passing on a model where no pair touches, slides or hands a joint over.)
#[test]
fn a_bar_thrown_on_a_slab_breaks_identically_on_any_rank_count() {
    let reference = same_on_any_rank_count(bar_thrown_on_a_slab, 600);
    let touching = reference.pairs.iter().filter(|p| p.touching).count();
    let handed = reference.handed_over.iter().filter(|&&h| h).count();
    let slipped = reference.pairs.iter().filter(|p| p.slip > 0.0).count();
    println!(
        "{} contact events, {touching} pairs touching, {slipped} slipping, {} joints broken, {handed} handed over",
        reference.contact_events.len(),
        reference.events.len()
    );
    assert!(
        touching > 50,
        "the bar must rest on the slab ({touching} pairs)"
    );
    assert!(slipped > 10, "pairs must slide ({slipped})");
    assert!(
        reference.events.len() > 20,
        "joints must break ({})",
        reference.events.len()
    );
    assert!(handed > 0, "broken joints must be handed over to contact");
}

/// A whole frame reads what rank 0 gathers (`Simulation::gather_frame_to_root`): the
/// nodes' positions and velocities, each joint's largest damage and the touching pairs'
/// outputs (contact force per node, pressure per tet). On 2 and 3 ranks, at steps 200, 400
/// and 600 of the thrown bar (joints damaged and broken, pairs touching and sliding), rank
/// 0's reads and nodes equal the one-process frame's bit for bit, the other ranks receive
/// nothing for it (they send their part), and the run goes on to the one-process state:
/// gathering to rank 0 leaves every rank's stepping state as it was. Reference: the
/// one-process run; tolerance none (the contact forces are summed in pair order on both).
#[test]
fn a_frame_gathers_to_rank_0_only_what_it_shows() {
    use fdem::pipeline::FrameReads;
    type Frame = (Vec<Vec3>, Vec<Vec3>, Vec<Real>, Vec<Vec3>, Vec<Real>);
    let frame_of = |sim: &Simulation, r: &FrameReads| -> Frame {
        (
            sim.nodes.x.clone(),
            sim.nodes.v.clone(),
            r.joint_damage.clone(),
            r.contact_force.clone(),
            r.contact_pressure.clone(),
        )
    };
    let at = [200, 400, 600];
    let (reference, end) = {
        let mut sim = bar_thrown_on_a_slab();
        let mut frames = Vec::new();
        for step in 1..=600 {
            sim.step().unwrap();
            if at.contains(&step) {
                let reads = sim
                    .gather_frame_to_root()
                    .expect("one process reads its own");
                frames.push(frame_of(&sim, &reads));
            }
        }
        (frames, outcome(&sim))
    };
    let (_, _, damage, force, pressure) = &reference[2];
    assert!(damage.iter().any(|&d| d > 0.0), "joints must be damaged");
    assert!(force.iter().any(|f| f.norm() > 0.0), "pairs must touch");
    assert!(pressure.iter().any(|&p| p > 0.0), "pairs must press");
    for ranks in 2..=3 {
        check_halo();
        let runs = ThreadComm::run(ranks, |comm| {
            let mut sim = bar_thrown_on_a_slab();
            sim.decompose(comm);
            let mut frames = Vec::new();
            let mut received = Vec::new();
            for step in 1..=600 {
                sim.step().unwrap();
                if at.contains(&step) {
                    let before = sim.exchanged().bytes;
                    let reads = sim.gather_frame_to_root();
                    received.push(sim.exchanged().bytes - before);
                    frames.push(reads.map(|r| frame_of(&sim, &r)));
                }
            }
            sim.synchronize();
            (sim.rank_and_size().0, frames, received, outcome(&sim))
        });
        for (rank, frames, received, o) in runs {
            let place = format!("rank {rank} of {ranks}");
            for (k, frame) in frames.into_iter().enumerate() {
                match frame {
                    Some(f) => {
                        assert_eq!(rank, 0, "{place}: only rank 0 reads a frame");
                        assert!(
                            f.0 == reference[k].0,
                            "{place}, frame {k}: positions differ"
                        );
                        assert!(
                            f.1 == reference[k].1,
                            "{place}, frame {k}: velocities differ"
                        );
                        assert!(
                            f.2 == reference[k].2,
                            "{place}, frame {k}: joint damage differs"
                        );
                        assert!(
                            f.3 == reference[k].3,
                            "{place}, frame {k}: contact forces differ"
                        );
                        assert!(
                            f.4 == reference[k].4,
                            "{place}, frame {k}: pressures differ"
                        );
                        assert!(
                            received[k] > 0,
                            "{place}: rank 0 receives the others' parts"
                        );
                    }
                    None => {
                        assert_ne!(rank, 0, "{place}: rank 0 reads every frame");
                        assert_eq!(received[k], 0, "{place}, frame {k}: receives nothing");
                    }
                }
            }
            assert!(
                o.x == end.x && o.v == end.v,
                "{place}: the run went elsewhere"
            );
            assert!(o.pairs == end.pairs, "{place}: contact histories differ");
            assert!(
                o.damage == end.damage,
                "{place}: joint damage differs at the end"
            );
        }
    }
}

/// A frame written in pieces (`vtk_pieces: "per_rank"`): each rank's piece is the tets
/// whose first node it owns, made from its own state and what its neighbours send
/// (`Simulation::piece_frame_reads`: the damage of joints at its tets designated elsewhere,
/// the outputs of touching pairs at its nodes). On 2 and 3 ranks with every node a rank
/// does not keep current poisoned (NaN), at three steps of the thrown bar, each rank's
/// positions, velocities, joint damage, contact forces and pressures at its piece equal the
/// one-process frame's bit for bit, and each rank receives less than every node's position
/// and velocity alone would be (a whole share also sends every joint's and pair's history). Reference: the one-process run; tolerance
/// none.
#[test]
fn a_piece_of_a_frame_is_made_from_its_rank_and_its_neighbours() {
    use fdem::pipeline::FrameReads;
    let at = [200, 400, 600];
    let mut sim = bar_thrown_on_a_slab();
    let mut reference = Vec::new();
    for step in 1..=600 {
        sim.step().unwrap();
        if at.contains(&step) {
            let r = FrameReads::of(&sim);
            reference.push((sim.nodes.x.clone(), sim.nodes.v.clone(), r));
        }
    }
    let bits = |v: Real| v.to_bits();
    let vec_bits = |v: &Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
    for ranks in 2..=3 {
        check_halo();
        let runs = ThreadComm::run(ranks, |comm| {
            let mut sim = bar_thrown_on_a_slab();
            sim.decompose(comm);
            let mut checked = [0usize; 3];
            for step in 1..=600 {
                sim.step().unwrap();
                let Some(k) = at.iter().position(|&a| a == step) else {
                    continue;
                };
                let before = sim.exchanged();
                let reads = sim.piece_frame_reads();
                let after = sim.exchanged();
                // What crosses pieces, not the whole model: less than every node's x and v.
                let received = after.whole - before.whole;
                let every_node = 48 * sim.nodes.len() as u64;
                assert!(
                    received < every_node,
                    "{received} bytes, every node {every_node}"
                );
                let (x, v, r) = &reference[k];
                let (rank, _) = sim.rank_and_size();
                let piece: Vec<usize> = (0..sim.tets.len())
                    .filter(|&e| sim.node_owner(sim.tets.nodes[e][0] as usize) == rank)
                    .collect();
                let place = format!("rank {rank} of {ranks}, step {step}");
                for &e in &piece {
                    for n in sim.tets.nodes[e].map(|n| n as usize) {
                        assert_eq!(vec_bits(&sim.nodes.x[n]), vec_bits(&x[n]), "{place}: x");
                        assert_eq!(vec_bits(&sim.nodes.v[n]), vec_bits(&v[n]), "{place}: v");
                        assert_eq!(
                            vec_bits(&reads.contact_force[n]),
                            vec_bits(&r.contact_force[n]),
                            "{place}: contact force at node {n}"
                        );
                    }
                    assert_eq!(
                        bits(reads.contact_pressure[e]),
                        bits(r.contact_pressure[e]),
                        "{place}: pressure of tet {e}"
                    );
                }
                for (j, tets) in sim.joints.tets.iter().enumerate() {
                    if tets
                        .iter()
                        .any(|&t| piece.binary_search(&(t as usize)).is_ok())
                    {
                        assert_eq!(
                            bits(reads.joint_damage[j]),
                            bits(r.joint_damage[j]),
                            "{place}: damage of joint {j}"
                        );
                        checked[0] += (r.joint_damage[j] > 0.0) as usize;
                    }
                }
                checked[1] += piece
                    .iter()
                    .filter(|&&e| r.contact_pressure[e] > 0.0)
                    .count();
                checked[2] += piece.len();
            }
            checked
        });
        let total = runs
            .iter()
            .fold([0; 3], |a, c| [a[0] + c[0], a[1] + c[1], a[2] + c[2]]);
        println!("{ranks} ranks: damaged joints, pressed tets, tets checked: {total:?}");
        assert!(
            total[0] > 0 && total[1] > 0,
            "the pieces must hold damage and contact"
        );
        assert_eq!(
            total[2],
            3 * sim.tets.len(),
            "every tet in one piece at each frame"
        );
    }
}

/// A checkpoint gathers the whole model to rank 0 alone
/// (`Simulation::with_whole_state_on_root`): on 2 and 3 ranks of the thrown bar, what rank 0
/// serializes is byte for byte what it serializes after every rank shared the whole state
/// (`Simulation::synchronize`, what checkpoints did before), the other ranks receive
/// nothing for it, and a run checkpointed so goes on to the one-process state (rank 0 puts
/// its own contact lists back). Reference: the shared state, and the one-process run;
/// tolerance none.
#[test]
fn a_checkpoint_gathers_the_whole_model_to_rank_0_alone() {
    let end = {
        let mut sim = bar_thrown_on_a_slab();
        for _ in 0..600 {
            sim.step().unwrap();
        }
        outcome(&sim)
    };
    for ranks in 2..=3 {
        check_halo();
        let runs = ThreadComm::run(ranks, |comm| {
            let mut sim = bar_thrown_on_a_slab();
            sim.decompose(comm);
            let mut compared = 0;
            for step in 1..=600 {
                sim.step().unwrap();
                if step == 250 || step == 450 {
                    let before = sim.exchanged().bytes;
                    let gathered =
                        sim.with_whole_state_on_root(|s| postcard::to_allocvec(s).unwrap());
                    let received = sim.exchanged().bytes - before;
                    let (rank, _) = sim.rank_and_size();
                    assert_eq!(gathered.is_some(), rank == 0, "rank {rank}");
                    if rank != 0 {
                        assert_eq!(received, 0, "rank {rank} receives nothing");
                    }
                    if step == 450 {
                        sim.synchronize();
                        let shared = postcard::to_allocvec(&sim).unwrap();
                        if let Some(g) = gathered {
                            assert!(g == shared, "rank 0's checkpoint differs at step {step}");
                            compared += 1;
                        }
                    }
                }
            }
            sim.synchronize();
            (compared, outcome(&sim))
        });
        assert_eq!(runs.iter().map(|r| r.0).sum::<usize>(), 1);
        for (rank, (_, o)) in runs.iter().enumerate() {
            assert!(o == &end, "rank {rank} of {ranks}: the run went elsewhere");
        }
    }
}

/// The model edited between steps, as a script may between runs: after 300 steps of the
/// thrown bar a second jointed block is added above the slab and its joints inserted, and
/// the run goes on 300 steps. The new split shares every node's, joint's and pair's state
/// first (the joints the ranks computed included: a script's run no longer shares them at
/// its end), and the new joints, the same on every rank, are no rank's yet. On 2 and 3
/// ranks the run ends in the one-process state. Reference: the one-process run; tolerance
/// none.
#[test]
fn a_model_edited_between_steps_goes_on_as_one_process() {
    let edit = |sim: &mut Simulation| {
        let m = 0;
        let b = sim
            .add_body(
                "block",
                &box_mesh(
                    Vec3::new(0.3, -0.05, 0.2),
                    Vec3::new(0.5, 0.05, 0.3),
                    [4, 2, 2],
                ),
                m,
                Layout::Jointed,
            )
            .unwrap();
        let law = cohesive(1e10, 1e6, 20.0, fdem::joints::law::Dilatancy::NONE);
        let id = sim.joints.add_law(JointLaw::Cohesive(law));
        let (body, tets, x0) = (
            sim.bodies[b].clone(),
            sim.tets.nodes.clone(),
            sim.nodes.x0.clone(),
        );
        sim.joints
            .insert_in_body(&body, &tets, &x0, id, |_| true)
            .unwrap();
        for n in sim.bodies[b].nodes.clone() {
            sim.nodes.v[n] = Vec3::new(0.0, 0.0, -3.0);
        }
        sim.invalidate();
    };
    let end = {
        let mut sim = bar_thrown_on_a_slab();
        for step in 1..=600 {
            sim.step().unwrap();
            if step == 300 {
                edit(&mut sim);
            }
        }
        outcome(&sim)
    };
    assert!(
        end.events.len() > 20,
        "joints must break ({})",
        end.events.len()
    );
    for ranks in 2..=3 {
        check_halo();
        let runs = ThreadComm::run(ranks, |comm| {
            let mut sim = bar_thrown_on_a_slab();
            sim.decompose(comm);
            for step in 1..=600 {
                sim.step().unwrap();
                if step == 300 {
                    edit(&mut sim);
                }
            }
            sim.synchronize();
            outcome(&sim)
        });
        for (rank, o) in runs.iter().enumerate() {
            assert!(
                o.x == end.x && o.v == end.v,
                "rank {rank} of {ranks}: nodes differ"
            );
            assert!(
                o.damage == end.damage,
                "rank {rank} of {ranks}: joint damage differs"
            );
            assert!(o == &end, "rank {rank} of {ranks}: the run went elsewhere");
        }
    }
}

/// Before a full detection a rank receives only the nodes within reach of its own (the
/// pairs of its tets cannot reach further: 2·e_max + skin), not every node: on 3 ranks
/// the thrown bar's ranks hold fewer positions than the model's at their last detections,
/// and receive fewer bytes for them than every node would cost (while the equality test
/// above shows the pairs found are the one-rank ones). Before, each rank received every
/// other rank's nodes (x, v and reaction, 72 bytes a node) at every detection; the first
/// too, which sets the default skin (now an exact sum over the ranks).
#[test]
fn before_a_detection_a_rank_receives_only_the_nodes_within_reach() {
    check_halo();
    let runs = ThreadComm::run(3, |comm| {
        let mut sim = bar_thrown_on_a_slab();
        sim.decompose(comm);
        let mut held = Vec::new();
        for _ in 0..600 {
            let before = sim.contact_detection.detector.detections;
            sim.step().unwrap();
            let d = &sim.contact_detection.detector;
            if d.detections > before && !d.current.is_empty() {
                held.push(d.current.iter().filter(|&&c| c).count());
            }
        }
        let e = sim.exchanged();
        (
            sim.nodes.len(),
            held,
            e.near,
            sim.contact_detection.detector.detections,
        )
    });
    let n = runs[0].0;
    for (rank, (_, held, near, detections)) in runs.iter().enumerate() {
        println!("rank {rank}: {detections} detections, positions held {held:?} of {n}, {near} bytes received for them");
        assert_eq!(
            held.len() as u64,
            *detections,
            "rank {rank}: every detection near ({held:?})"
        );
        assert!(!held.is_empty(), "rank {rank}: detections must run");
    }
    // Every node to every rank at each detection: 2·n nodes received per detection over the
    // 3 ranks.
    let every_node = (runs[0].1.len() * 2 * n * 72) as u64;
    let near: u64 = runs.iter().map(|r| r.2).sum();
    println!("received before detections: {near} bytes, every node would be {every_node}");
    assert!(near < every_node, "{near} bytes, every node {every_node}");
    assert!(
        runs.iter().any(|r| r.1.iter().any(|&h| h < n)),
        "some rank must hold less than every node"
    );
}

/// A friction law that turns negative once a pair slips faster than 0.5 m/s (μ = 0.5 − v)
/// stops the run; on 2, 3 and 4 ranks every rank stops at the one-rank step with the
/// one-rank message (the first failing pair in pair order, merged from the pairs' records).
#[test]
fn a_failing_friction_law_stops_every_rank_where_one_rank_stops() {
    let build = || {
        let mut sim = bar_thrown_on_a_slab();
        let ast = rhai::Engine::new_raw()
            .compile("fn mu(c, p) { p.mu0 - p.k * c.slip_rate }")
            .unwrap();
        let mut params = rhai::Map::new();
        params.insert("mu0".into(), (0.5 as Real).into());
        params.insert("k".into(), (1.0 as Real).into());
        let law = fdem::compiled::compile_with(
            &ast,
            "mu",
            &params,
            fdem::contact_interaction::FRICTION_LAW,
        )
        .unwrap();
        sim.contact.laws.rules[0] = fdem::contact_interaction::ContactRule::from(
            fdem::contact_interaction::PotentialContact {
                friction: 0.5,
                damping: 0.1,
                friction_law: Some(std::sync::Arc::new(law)),
                ..Default::default()
            },
        );
        sim
    };
    let stop = |sim: &mut Simulation| -> (u64, String) {
        for _ in 0..2000 {
            if let Err(e) = sim.step() {
                return (sim.step, e.to_string());
            }
        }
        panic!("the law must fail within 2000 steps");
    };
    let reference = stop(&mut build());
    println!("one rank stops at step {}: {}", reference.0, reference.1);
    assert!(reference.1.contains("friction law 'mu'"), "{}", reference.1);
    for ranks in 2..=4 {
        check_halo();
        let runs = ThreadComm::run(ranks, |comm| {
            let mut sim = build();
            sim.decompose(comm);
            stop(&mut sim)
        });
        for (rank, got) in runs.into_iter().enumerate() {
            assert_eq!(got, reference, "rank {rank} of {ranks}");
        }
    }
}

/// A reinforced concrete beam struck by a rigid weight: a jointed beam 1 × 0.1 × 0.1 m
/// (24 × 4 × 4 Kuhn cells, 2 304 tets, 9 216 nodes: 5 of stage 7's chunks) on two supports,
/// two bending bars bonded to it (fib 2010 bond), and a rigid 10 kg box thrown on it at
/// mid-span at 5 m/s with contact and friction. The rigid body's nodes are the last rank's;
/// the bars' and their hosts' nodes span every rank.
fn reinforced_beam_struck_by_a_rigid_weight() -> Simulation {
    use fdem::elements::bar2::steel::{Steel, SteelLaw};
    use fdem::joints::bond::{BondLaw, Envelope, Fib2010};
    let (e, rho, ft) = (3e10, 2400.0, 2e6);
    let mut sim = Simulation::new();
    let concrete = sim.add_material(Material::new(Formulation::Munjiza, rho, e, 0.2, 0.0).unwrap());
    sim.add_body(
        "beam",
        &box_mesh(
            Vec3::new(0.0, -0.05, 0.0),
            Vec3::new(1.0, 0.05, 0.1),
            [24, 4, 4],
        ),
        concrete,
        Layout::Jointed,
    )
    .unwrap();
    let law = cohesive(e, ft, 20.0, fdem::joints::law::Dilatancy::NONE);
    let id = sim.joints.add_law(JointLaw::Cohesive(law));
    let (body, tets, x0) = (
        sim.bodies[0].clone(),
        sim.tets.nodes.clone(),
        sim.nodes.x0.clone(),
    );
    sim.joints
        .insert_in_body(&body, &tets, &x0, id, |_| true)
        .unwrap();
    let steel = sim.add_steel(Steel {
        density: 7850.0,
        young: 200e9,
        yield_stress: 464e6,
        hardening: 1e9,
        rupture_strain: 0.2,
        rate: None,
        law: SteelLaw::Bilinear,
    });
    let fib = Fib2010::new(30e6, "confined", true, 8e-3).unwrap();
    let bond = sim.add_bond_law(BondLaw {
        envelope: Envelope::Fib2010(fib),
        stiffness: fib.envelope(fib.s1 / 100.0) / (fib.s1 / 100.0),
        transverse_stiffness: None,
    });
    for (k, y) in [-0.025, 0.025].into_iter().enumerate() {
        sim.add_rebar(&fdem::pipeline::RebarSpec {
            name: format!("bottom {k}"),
            host: 0,
            points: vec![Vec3::new(0.02, y, 0.02), Vec3::new(0.98, y, 0.02)],
            diameter: 8e-3,
            area: None,
            steel,
            bond_law: bond,
            segment: Some(0.04),
            bending: true,
        })
        .unwrap();
    }
    let weight = sim
        .add_body(
            "weight",
            &box_mesh(
                Vec3::new(0.45, -0.04, 0.1005),
                Vec3::new(0.55, 0.04, 0.1505),
                [2, 2, 1],
            ),
            concrete,
            Layout::Rigid,
        )
        .unwrap();
    sim.set_body_velocity(weight, Vec3::new(0.0, 0.0, -5.0));
    let support = |x: Real| {
        sim.nodes_in(
            &Region::Box {
                min: Vec3::new(x - 0.03, -1.0, -1e-6),
                max: Vec3::new(x + 0.03, 1.0, 1e-6),
            },
            None,
        )
    };
    let held: Vec<u32> = support(0.05).into_iter().chain(support(0.95)).collect();
    sim.loads.prescribed.push(PrescribedVelocity {
        nodes: held,
        components: [None, None, Some(TimeFunction::Constant(0.0))],
    });
    sim.contact
        .laws
        .rules
        .push(fdem::contact_interaction::ContactRule::from(
            fdem::contact_interaction::PotentialContact {
                friction: 0.5,
                damping: 0.1,
                ..Default::default()
            },
        ));
    sim.contact.record_events = true;
    sim.loads.gravity = Vec3::new(0.0, 0.0, -9.81);
    sim.settings.energy_every = 5;
    sim
}

/// Rebars and rigid bodies: the struck reinforced beam on 2, 3 and 4 ranks gives the
/// one-rank run's bits, the weight's motion and the bars' and bond points' states included.
/// (Reference: the one-rank run; the checks below keep the test from passing on a model
/// where the weight never lands or the bars carry nothing.)
#[test]
fn a_reinforced_beam_struck_by_a_rigid_weight_moves_identically_on_any_rank_count() {
    let reference = same_on_any_rank_count(reinforced_beam_struck_by_a_rigid_weight, 800);
    let [_, v, _, _] = reference.rigid[0];
    let touching = reference.pairs.iter().filter(|p| p.touching).count();
    let stresses = &reference.rebars[..reference.rebars.len() / 2];
    let bars = reinforced_beam_struck_by_a_rigid_weight().bars.stress.len();
    let largest_stress = stresses[..bars]
        .iter()
        .fold(0.0 as Real, |a, s| a.max(s.abs()));
    println!(
        "weight at {:.3} m/s, {touching} pairs touching, {} joints broken, largest bar stress {:.1} MPa",
        v.z,
        reference.events.len(),
        largest_stress / 1e6
    );
    assert!(v.z > 0.0, "the weight must land and rebound ({} m/s)", v.z);
    assert!(
        touching > 4,
        "the weight must rest on the beam ({touching})"
    );
    assert!(reference.events.len() > 10, "the beam must crack");
    assert!(largest_stress > 10e6, "the bars must carry the blow");
}

/// Rebars without contact: the pulled jointed bar with a bonded bar along its axis. Only
/// the bars' and their hosts' nodes tie the ranks' bond points together (nothing exports
/// every node), and 2, 3, 4 ranks give the one-rank run's bits. (Reference: the one-rank
/// run; the bar must break and the rebar take the load.)
#[test]
fn a_reinforced_jointed_bar_breaks_identically_on_any_rank_count() {
    let build = || {
        use fdem::elements::bar2::steel::{Steel, SteelLaw};
        use fdem::joints::bond::{BondLaw, Envelope, Fib2010};
        let mut sim = pulled_jointed_bar();
        let steel = sim.add_steel(Steel {
            density: 7850.0,
            young: 200e9,
            yield_stress: 464e6,
            hardening: 1e9,
            rupture_strain: 0.2,
            rate: None,
            law: SteelLaw::Bilinear,
        });
        let fib = Fib2010::new(30e6, "confined", true, 8e-3).unwrap();
        let bond = sim.add_bond_law(BondLaw {
            envelope: Envelope::Fib2010(fib),
            stiffness: fib.envelope(fib.s1 / 100.0) / (fib.s1 / 100.0),
            transverse_stiffness: None,
        });
        sim.add_rebar(&fdem::pipeline::RebarSpec {
            name: "axis".into(),
            host: 0,
            points: vec![Vec3::new(0.01, 0.04, 0.04), Vec3::new(0.99, 0.04, 0.04)],
            diameter: 8e-3,
            area: None,
            steel,
            bond_law: bond,
            segment: Some(0.02),
            bending: true,
        })
        .unwrap();
        sim
    };
    let reference = same_on_any_rank_count(build, 2000);
    let bars = build().bars.stress.len();
    let largest_stress = reference.rebars[..bars]
        .iter()
        .fold(0.0 as Real, |a, s| a.max(s.abs()));
    println!(
        "{} joints broken, largest bar stress {:.1} MPa",
        reference.events.len(),
        largest_stress / 1e6
    );
    assert!(reference.events.len() >= 32, "the bar must crack through");
    assert!(largest_stress > 10e6, "the rebar must take the load");
}

/// Started by an MPI launcher as one of several ranks, an fdem built without MPI refuses to
/// run (each process would run the whole model and write the same files) and says how to
/// build one with it.
#[cfg(not(feature = "mpi"))]
#[test]
fn a_launch_on_several_ranks_without_mpi_is_refused() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fdem"))
        .args([
            "run",
            "scripts/cantilever.rhai",
            "--set",
            "quick=true",
            "--quiet",
        ])
        .env("OMPI_COMM_WORLD_SIZE", "2")
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "ran: {err}");
    assert!(
        err.contains("one of 2") && err.contains("--features mpi"),
        "{err}"
    );
}

/// The summary's load balance: after `gather_rank_timings` every rank holds every rank's
/// stage and exchange times, each rank's entry equal to that rank's own timers (the values
/// are sent as they are, in one exact sum with one rank non-zero per entry), and every
/// rank's peak resident memory (on Linux).
#[test]
fn every_rank_sees_every_ranks_stage_times() {
    check_halo();
    let runs = ThreadComm::run(3, |comm| {
        let mut sim = continuous_bodies();
        sim.decompose(comm);
        for _ in 0..20 {
            sim.step().unwrap();
        }
        sim.gather_rank_timings();
        let (rank, _) = sim.rank_and_size();
        let own = fdem::parallel::RankSeconds {
            stages: sim.timers.seconds,
            exchange: sim.exchanged().seconds,
            pairs_held: 0.0,
            peak_memory: 0.0,
        };
        (rank, own, sim.rank_seconds().to_vec())
    });
    // (The ranks are threads of this process here: their peak memory is the process's,
    // read by each at its own moment; it is compared apart.)
    let linux = std::path::Path::new("/proc/self/status").exists();
    let runs: Vec<_> = runs
        .into_iter()
        .map(|(rank, own, mut seen)| {
            for r in &mut seen {
                assert!(
                    !linux || r.peak_memory > 1e6,
                    "rank {rank} sees a peak memory of {} B",
                    r.peak_memory
                );
                r.peak_memory = 0.0;
            }
            (rank, own, seen)
        })
        .collect();
    let own: Vec<_> = {
        let mut v: Vec<_> = runs.iter().map(|(r, o, _)| (*r, *o)).collect();
        v.sort_by_key(|(r, _)| *r);
        v.into_iter().map(|(_, o)| o).collect()
    };
    for (rank, _, seen) in &runs {
        assert_eq!(
            seen, &own,
            "rank {rank} sees other times than the ranks' own"
        );
        assert!(
            seen.iter().all(|r| r.stages[0] > 0.0),
            "stage 1 ran on every rank"
        );
    }
}

/// A fracture criterion that keeps fully damaged joints pending (`when: "damaged"`: they
/// break once they opened to a limit) across a restart onto ranks: a one-process checkpoint
/// taken while joints wait, restored on 2 and 3 ranks, goes on as the one process does (the
/// same positions, broken joints and break events, the waiting joints breaking after the
/// restart). A rank's list of waiting joints is made again at each split from the joints it
/// holds; the restored list was the writing process's, and named joints a rank does not hold
/// (it panicked there once ranks held only their own joint histories; before that, such a
/// rank asked the criterion about stale histories).
#[test]
fn joints_a_criterion_keeps_waiting_go_on_alike_after_a_restart_on_ranks() {
    check_halo();
    let with_criterion = || {
        let mut sim = pulled_jointed_bar();
        let src = "fn criterion(j, p) { j.max_opening > p.limit }";
        let ast = rhai::Engine::new_raw().compile(src).unwrap();
        let mut p = rhai::Map::new();
        p.insert("limit".into(), 4e-4.into());
        let law =
            fdem::compiled::compile_with(&ast, "criterion", &p, fdem::fracture::CRITERION).unwrap();
        sim.fracture_criterion = Some(fdem::fracture::FractureCriterion::new(
            std::sync::Arc::new(law),
            fdem::fracture::CriterionWhen::Damaged,
        ));
        sim
    };
    let waiting = |sim: &Simulation| {
        (0..sim.joints.len())
            .filter(|&j| {
                !sim.joints.broken[j] && sim.joints.state[j].iter().all(|p| p.damage >= 1.0)
            })
            .count()
    };
    let mut one = with_criterion();
    while waiting(&one) < 8 {
        one.step().unwrap();
        assert!(one.step < 20_000, "no joint failed");
    }
    let (at, broken_at) = (one.step, one.break_events.len());
    let bytes = postcard::to_allocvec(&one).unwrap();
    let steps = 1500;
    for _ in 0..steps {
        one.step().unwrap();
    }
    println!(
        "checkpoint at step {at} with {} joints waiting and {broken_at} broken; {} broken {steps} steps later",
        8,
        one.break_events.len()
    );
    assert!(
        one.break_events.len() > broken_at,
        "no waiting joint broke after the restart: the test would not see them"
    );
    for ranks in [2, 3] {
        let runs = ThreadComm::run(ranks, |comm| {
            let mut sim = with_criterion();
            sim.decompose(comm);
            sim.step().unwrap();
            sim.restore(postcard::from_bytes(&bytes).unwrap());
            for _ in 0..steps {
                sim.step().unwrap();
            }
            sim.synchronize();
            let (rank, _) = sim.rank_and_size();
            (
                rank,
                sim.nodes.x.clone(),
                sim.joints.broken.clone(),
                sim.break_events.clone(),
            )
        });
        for (rank, x, broken, events) in runs {
            let place = format!("rank {rank} of {ranks}");
            assert!(x == one.nodes.x, "{place}: positions differ");
            assert_eq!(broken, one.joints.broken, "{place}: broken joints differ");
            assert_eq!(events, one.break_events, "{place}: break events differ");
        }
    }
}
