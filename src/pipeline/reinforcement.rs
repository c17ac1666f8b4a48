//! Building reinforcement: steels, bond laws and rebars laid along polylines and embedded in
//! a host body (bar elements of stage 1, bond points of stage 2).

use super::Simulation;
use crate::elements::bar2::steel::Steel;
use crate::joints::bond::{BondLaw, BondPoint};
use crate::math::{Real, Vec3};
use crate::state::{Layout, Rebar};

/// A rebar to lay: a polyline (closed when its last point is its first: a stirrup), its
/// diameter, steel and bond law, and the largest bar element length.
#[derive(Clone, Debug)]
pub struct RebarSpec {
    pub name: String,
    pub host: usize,
    pub points: Vec<Vec3>,
    /// d [m]: section A₀ = πd²/4, bond perimeter πd.
    pub diameter: Real,
    /// Section A₀ [m²] when it is not πd²/4 (a nominal bar area).
    pub area: Option<Real>,
    pub steel: u32,
    pub bond_law: u32,
    /// Largest bar element length [m]; None: the host's mean element size.
    pub segment: Option<Real>,
    /// Bending hinges at the bar nodes (dowel action); false: a chain of pins.
    pub bending: bool,
}

impl Simulation {
    pub fn add_steel(&mut self, s: Steel) -> u32 {
        self.ready = false;
        self.steels.push(s);
        (self.steels.len() - 1) as u32
    }

    pub fn add_bond_law(&mut self, law: BondLaw) -> u32 {
        self.bonds.add_law(law)
    }

    /// Lay a rebar: split the polyline into bars no longer than the segment length, tie each
    /// bar node to the host tetrahedron that holds it (barycentric coordinates in the
    /// reference placement) with a bond point of tributary length L_b. Errors name the rebar
    /// and, for a point outside the host, the point.
    pub fn add_rebar(&mut self, spec: &RebarSpec) -> Result<usize, String> {
        let name = &spec.name;
        let who = format!("rebar '{name}'");
        if self.step > 0 {
            return Err(format!("{who}: rebars must be laid before the first step"));
        }
        if self.rebars.iter().any(|r| &r.name == name) {
            return Err(format!("a rebar named '{name}' already exists"));
        }
        if !(spec.diameter > 0.0 && spec.diameter.is_finite()) {
            return Err(format!(
                "{who}: diameter must be > 0 m, got {}",
                spec.diameter
            ));
        }
        if let Some(a) = spec.area.filter(|a| !(*a > 0.0 && a.is_finite())) {
            return Err(format!("{who}: area must be > 0 m², got {a}"));
        }
        let host = self
            .bodies
            .get(spec.host)
            .ok_or_else(|| format!("{who}: unknown host body {}", spec.host))?;
        if host.layout != Layout::Jointed && host.layout != Layout::Continuous {
            return Err(format!(
                "{who}: the host body '{}' is {}: bars are embedded only in deformable bodies",
                host.name,
                host.layout.name()
            ));
        }
        if spec.steel as usize >= self.steels.len()
            || spec.bond_law as usize >= self.bonds.laws.len()
        {
            return Err(format!("{who}: unknown steel or bond law"));
        }
        let segment = match spec.segment {
            Some(h) if h > 0.0 && h.is_finite() => h,
            Some(h) => return Err(format!("{who}: segment must be > 0 m, got {h}")),
            None => 1.2 * (host.mesh.volume() / host.mesh.tets.len() as Real).cbrt(),
        };
        let (points, closed) = subdivide(&spec.points, segment, self.length_tolerance())
            .map_err(|e| format!("{who}: {e}"))?;
        let located = crate::mesh::locate::locate_points(&host.mesh, &points, 1e-9);
        if let Some(k) = located.iter().position(|l| l.is_none()) {
            let p = points[k];
            return Err(format!(
                "{who}: point {k} of the bar at ({:.6}, {:.6}, {:.6}) lies outside its host body '{}' (bars must lie inside the host; check the cover and the host's placement)",
                p.x, p.y, p.z, host.name
            ));
        }
        self.ready = false;
        let (host_id, tet_start) = (spec.host, host.tets.start);
        let host_young = self.materials[host.material as usize].young;
        let id = self.rebars.len();
        let node_start = self.nodes.len();
        for p in &points {
            self.nodes.push(*p, host_id as u32);
        }
        let n = points.len();
        let node = |i: usize| (node_start + i % n) as u32;
        let n_bars = if closed { n } else { n - 1 };
        let area = spec
            .area
            .unwrap_or(std::f64::consts::PI * spec.diameter * spec.diameter / 4.0);
        let bar_start = self.bars.len();
        let mut tributary = vec![0.0; n];
        for i in 0..n_bars {
            let l0 = (points[(i + 1) % n] - points[i]).norm();
            self.bars
                .push([node(i), node(i + 1)], l0, area, spec.steel, id as u32);
            tributary[i] += 0.5 * l0;
            tributary[(i + 1) % n] += 0.5 * l0;
        }
        if spec.bending {
            self.add_hinges(spec, &points, closed, node_start, bar_start);
        }
        let law = &self.bonds.laws[spec.bond_law as usize];
        let kt = law
            .transverse_stiffness
            .unwrap_or(host_young / spec.diameter);
        for (i, l) in located.into_iter().enumerate() {
            let (local, weights) = l.expect("checked above");
            let tet = tet_start + local;
            let corners = self.tets.nodes[tet].map(|c| self.nodes.x0[c as usize]);
            let xh: Vec3 = (0..4).map(|a| corners[a] * weights[a]).sum();
            let along = match (closed, i) {
                (true, _) => [node(i + n - 1), node(i + 1)],
                (false, 0) => [node(0), node(1)],
                (false, i) if i == n - 1 => [node(i - 1), node(i)],
                (false, i) => [node(i - 1), node(i + 1)],
            };
            self.bonds.push(BondPoint {
                node: node(i),
                along,
                tet: tet as u32,
                weights,
                offset0: points[i] - xh,
                area: std::f64::consts::PI * spec.diameter * tributary[i],
                diameter: spec.diameter,
                transverse_stiffness: kt,
                law: spec.bond_law,
            });
        }
        self.rebars.push(Rebar {
            name: name.clone(),
            diameter: spec.diameter,
            host: host_id,
            nodes: node_start..self.nodes.len(),
            bars: bar_start..self.bars.len(),
            steel: spec.steel,
        });
        Ok(id)
    }

    /// Bending hinges where two bars of the rebar just laid meet (all nodes of a closed one,
    /// the interior ones of an open one): k = EI/L̄ (I = πd⁴/64), M_p = f_y d³/6.
    fn add_hinges(
        &mut self,
        spec: &RebarSpec,
        points: &[Vec3],
        closed: bool,
        node_start: usize,
        bar_start: usize,
    ) {
        let steel = &self.steels[spec.steel as usize];
        let d = spec.diameter;
        let ei = steel.young * std::f64::consts::PI * d.powi(4) / 64.0;
        let mp = steel.yield_stress * d.powi(3) / 6.0;
        let n = points.len();
        let node = |i: usize| (node_start + i) as u32;
        let inner = if closed { 0..n } else { 1..n - 1 };
        for i in inner {
            let (prev, next) = ((i + n - 1) % n, (i + 1) % n);
            // Bar k runs from point k to point k + 1.
            let (b1, b2) = (bar_start + prev, bar_start + i);
            let mean = 0.5 * (self.bars.length0[b1] + self.bars.length0[b2]);
            // Along a straight leg the reference angle is rounding (~1e-16): take it as 0, so
            // that the force factor M/sin θ has its limit k where the bar is straight.
            let angle0 = crate::elements::bar2::hinge::turning_angle(
                &points[prev],
                &points[i],
                &points[next],
            );
            let angle0 = if angle0 < 1e-9 { 0.0 } else { angle0 };
            self.bars.hinges.push(
                [node(prev), node(i), node(next)],
                [b1 as u32, b2 as u32],
                ei / mean,
                mp,
                angle0,
            );
        }
    }
}

/// The polyline's points with every leg split into equal parts no longer than `segment`;
/// closed when the last point repeats the first (within `tol`; the repeat is dropped).
fn subdivide(points: &[Vec3], segment: Real, tol: Real) -> Result<(Vec<Vec3>, bool), String> {
    if points.len() < 2 {
        return Err(format!(
            "points must hold at least 2 points, got {}",
            points.len()
        ));
    }
    if let Some(k) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("point {k} is not finite"));
    }
    let closed = points.len() > 2 && (points[0] - points[points.len() - 1]).norm() <= tol;
    let corners = if closed {
        &points[..points.len() - 1]
    } else {
        points
    };
    let legs = if closed {
        corners.len()
    } else {
        corners.len() - 1
    };
    let mut out = Vec::new();
    for i in 0..legs {
        let (a, b) = (corners[i], corners[(i + 1) % corners.len()]);
        let len = (b - a).norm();
        if len <= tol {
            return Err(format!("points {i} and {} coincide", i + 1));
        }
        let parts = (len / segment).ceil().max(1.0) as usize;
        if parts > 1_000_000 {
            return Err(format!(
                "leg {i} of length {len} m would need {parts} bars of at most {segment} m"
            ));
        }
        for k in 0..parts {
            out.push(a + (b - a) * (k as Real / parts as Real));
        }
    }
    if !closed {
        out.push(corners[corners.len() - 1]);
    }
    Ok((out, closed))
}
