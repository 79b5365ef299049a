//! Paper 000's comparisons of its bee model with the curl-noise model, Brownian motion and
//! boids (Sec. VII–VIII, Figs. 5, 7 and 9), as numbers instead of pictures.
//!
//! The paper shows these comparisons only as images; it never says how it counted. The
//! functions here give each claim a precise, measurable form:
//!
//! - **Fig. 7** ("collision statistics in a dense setting"): [`contacts`] counts pairs of
//!   agents closer than a contact distance, frame by frame, and how often a new contact
//!   starts.
//! - **Fig. 9** (boids are too aligned; bees are "low-aligned and inherently noisy"):
//!   [`alignment`] measures the swarm's polarisation and how closely each agent's heading
//!   agrees with its nearest neighbour's.
//! - **Fig. 5** (the curl-noise model is "chaotic but unsmooth ... with an abrupt turn", the
//!   oscillation model too regular, the bee model smooth but noisy and zigzagging):
//!   [`trajectory_shape`] measures the yaw-rate spectrum and its dominant frequency, the
//!   turn rate and angular acceleration (paper 000 Eq. 16–17), and how often the horizontal
//!   path changes the sign of its curvature (zigzags).
//!
//! They are pure functions of recorded tracks held in memory ([`Frames`]): per frame, each
//! agent's position (metres) and velocity (m/s) at a known frame rate. They know nothing of
//! the simulation that made the tracks. The world is Y-up and right-handed (as everywhere in
//! beeswarm): the horizontal plane is X–Z.
//!
//! Angles between vectors are computed as `atan2(|a × b|, a · b)`, equal to the paper's
//! arccos of the normalised dot product but exact near 0 and π. Results never contain NaN:
//! a quantity without any sample to define it is `None`. See docs/validation.md, "Paper
//! 000's comparisons (Figs. 5, 7, 9)".

use crate::error::{Error, Result};
use glam::{DVec3, Vec3};

/// Speeds (m/s) at or below this have no direction; see [`ShapeOptions::min_speed`].
pub const MIN_SPEED: f64 = 1e-6;

/// Recorded tracks of a swarm: for every frame, every agent's position and velocity.
///
/// Agent `a` is the same individual in every frame (`positions[f][a]`), and every frame holds
/// the same number of agents. Frames are `1 / fps` seconds apart. Built with [`Frames::new`],
/// which checks all of this, so the metric functions never meet inconsistent input.
#[derive(Clone, Debug, PartialEq)]
pub struct Frames {
    fps: f64,
    positions: Vec<Vec<Vec3>>,
    velocities: Vec<Vec<Vec3>>,
}

impl Frames {
    /// `positions[frame][agent]` in metres and `velocities[frame][agent]` in m/s, sampled at
    /// `fps` frames per second.
    ///
    /// Errors (input errors) when `fps` is not finite and positive, when the two lists have
    /// different numbers of frames, when a frame holds a different number of agents than the
    /// first, or when a value is not finite.
    pub fn new(fps: f64, positions: Vec<Vec<Vec3>>, velocities: Vec<Vec<Vec3>>) -> Result<Self> {
        if !(fps.is_finite() && fps > 0.0) {
            return Err(Error::input(format!(
                "frame rate must be finite and positive, got {fps}"
            )));
        }
        if positions.len() != velocities.len() {
            return Err(Error::input(format!(
                "{} frames of positions but {} frames of velocities",
                positions.len(),
                velocities.len()
            )));
        }
        let agents = positions.first().map_or(0, Vec::len);
        for (f, (p, v)) in positions.iter().zip(&velocities).enumerate() {
            if p.len() != agents || v.len() != agents {
                return Err(Error::input(format!(
                    "frame {f} has {} positions and {} velocities, expected {agents} agents as in frame 0",
                    p.len(),
                    v.len()
                )));
            }
            if let Some(a) = (0..agents).find(|&a| !(p[a].is_finite() && v[a].is_finite())) {
                return Err(Error::input(format!(
                    "frame {f}, agent {a}: position or velocity is not finite"
                )));
            }
        }
        Ok(Frames {
            fps,
            positions,
            velocities,
        })
    }

    /// Frames per second.
    pub fn fps(&self) -> f64 {
        self.fps
    }
    /// Number of frames.
    pub fn len(&self) -> usize {
        self.positions.len()
    }
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
    /// Number of agents (the same in every frame).
    pub fn agents(&self) -> usize {
        self.positions.first().map_or(0, Vec::len)
    }
    /// Seconds from the first frame to the last: `(frames − 1) / fps` (0 for fewer than two).
    pub fn duration(&self) -> f64 {
        self.len().saturating_sub(1) as f64 / self.fps
    }
    /// `positions()[frame][agent]`, metres.
    pub fn positions(&self) -> &[Vec<Vec3>] {
        &self.positions
    }
    /// `velocities()[frame][agent]`, m/s.
    pub fn velocities(&self) -> &[Vec<Vec3>] {
        &self.velocities
    }
    /// One agent's velocities over all frames.
    pub fn agent_velocities(&self, agent: usize) -> Vec<Vec3> {
        self.velocities.iter().map(|f| f[agent]).collect()
    }
}

// ---------------------------------------------------------------------------------------
// Spatial grid
// ---------------------------------------------------------------------------------------

type Cell = [i64; 3];

/// Agents of one frame sorted into cubic cells of side `cell` metres. Sorting by
/// (x, y, z) cell and index keeps a column of cells along z contiguous, so a block of
/// cells is a few binary searches away, with no hashing and a deterministic order.
struct Grid {
    cell: f64,
    /// (cell, agent index), sorted.
    sorted: Vec<(Cell, u32)>,
}

impl Grid {
    fn new(points: &[Vec3], cell: f64) -> Self {
        let mut sorted: Vec<(Cell, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| (cell_of(*p, cell), i as u32))
            .collect();
        sorted.sort_unstable();
        Grid { cell, sorted }
    }
    fn key(&self, p: Vec3) -> Cell {
        cell_of(p, self.cell)
    }
    /// Agents in cells `[x, y, z]` for z in `z0..=z1`.
    fn column(&self, x: i64, y: i64, z0: i64, z1: i64) -> impl Iterator<Item = u32> + '_ {
        let lo = self.sorted.partition_point(|(c, _)| *c < [x, y, z0]);
        let hi = lo + self.sorted[lo..].partition_point(|(c, _)| *c <= [x, y, z1]);
        self.sorted[lo..hi].iter().map(|&(_, i)| i)
    }
}

fn cell_of(p: Vec3, cell: f64) -> Cell {
    let p = p.as_dvec3() / cell;
    // `as` saturates: absurdly far points share edge cells, which costs speed, not results.
    [p.x.floor() as i64, p.y.floor() as i64, p.z.floor() as i64]
}

/// Pairs `(i, j)`, `i < j`, of points strictly closer than `d`, sorted. With cells of side
/// `d` such a pair lies in the same or adjacent cells, so each point looks at 27 cells:
/// O(n) for a bounded density.
fn close_pairs(points: &[Vec3], d: f64) -> Vec<(u32, u32)> {
    let mut pairs = Vec::new();
    if !(d.is_finite() && d > 0.0) || points.len() < 2 {
        return pairs;
    }
    let grid = Grid::new(points, d);
    let d2 = d * d;
    for (i, p) in points.iter().enumerate() {
        let c = grid.key(*p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                let column = grid.column(
                    c[0].saturating_add(dx),
                    c[1].saturating_add(dy),
                    c[2].saturating_sub(1),
                    c[2].saturating_add(1),
                );
                for j in column {
                    if (j as usize) > i
                        && p.as_dvec3().distance_squared(points[j as usize].as_dvec3()) < d2
                    {
                        pairs.push((i as u32, j));
                    }
                }
            }
        }
    }
    pairs.sort_unstable();
    pairs
}

/// Index of each point's nearest other point (`None` with fewer than two points). Ties go
/// to the lower index, so the result does not depend on the search order.
///
/// Cells are sized so that about one point falls in each (the bounding box's longest side
/// over ∛n), and the search visits rings of cells at growing Chebyshev distance r from the
/// point's own cell, stopping once the best distance found is below r cells: every point
/// in a farther ring is at least that far. O(n) per frame for a swarm filling its box.
fn nearest_neighbours(points: &[Vec3]) -> Vec<Option<u32>> {
    let n = points.len();
    if n < 2 {
        return vec![None; n];
    }
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p.as_dvec3()), hi.max(p.as_dvec3())),
    );
    let extent = (hi - lo).max_element();
    if extent <= 0.0 {
        // All points coincide: every other point is at distance 0; the lowest index wins.
        return (0..n).map(|i| Some(if i == 0 { 1 } else { 0 })).collect();
    }
    let cell = extent / (n as f64).cbrt();
    let grid = Grid::new(points, cell);
    // Rings beyond this cover the whole bounding box.
    let max_ring = (extent / cell).ceil() as i64 + 1;
    let mut out = Vec::with_capacity(n);
    for (i, p) in points.iter().enumerate() {
        let c = grid.key(*p);
        let pd = p.as_dvec3();
        let mut best: Option<(f64, u32)> = None;
        for r in 0..=max_ring {
            for dx in -r..=r {
                for dy in -r..=r {
                    let (x, y) = (c[0].saturating_add(dx), c[1].saturating_add(dy));
                    let (z0, z1) = (c[2].saturating_sub(r), c[2].saturating_add(r));
                    // On the ring's x or y faces the whole column of 2r+1 cells; inside
                    // them only its two end cells (the z faces). (1, 0) is an empty range.
                    let ends: [(i64, i64); 2] = if dx.abs().max(dy.abs()) == r {
                        [(z0, z1), (1, 0)]
                    } else {
                        [(z0, z0), (z1, z1)]
                    };
                    for (za, zb) in ends {
                        if za > zb {
                            continue;
                        }
                        for j in grid.column(x, y, za, zb) {
                            if j as usize == i {
                                continue;
                            }
                            let d2 = pd.distance_squared(points[j as usize].as_dvec3());
                            if best.is_none_or(|(b2, bj)| (d2, j) < (b2, bj)) {
                                best = Some((d2, j));
                            }
                        }
                    }
                }
            }
            // Points in rings beyond r are at least r·cell away; strict so ties are settled.
            if let Some((b2, _)) = best
                && b2.sqrt() < r as f64 * cell
            {
                break;
            }
        }
        out.push(best.map(|(_, j)| j));
    }
    out
}

// ---------------------------------------------------------------------------------------
// Fig. 7: contacts
// ---------------------------------------------------------------------------------------

/// Contact statistics of a swarm (paper 000 Fig. 7).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Contacts {
    /// Contact-frames: Σ over frames of the number of agent pairs closer than the contact
    /// distance in that frame. A pair touching for k frames counts k.
    pub contact_frames: u64,
    /// Contacts that start: pairs in contact in a frame but not in the frame before. A pair
    /// already in contact in the first frame is not counted (its start was not seen).
    pub new_contacts: u64,
    /// New contacts per agent per second: `2 · new_contacts / (agents · duration)`, with
    /// duration `(frames − 1) / fps` seconds. Each new pair contact is a contact for both of
    /// its agents, hence the 2: this is how often one agent runs into another. `None` with
    /// fewer than two frames or no agents.
    pub new_per_agent_second: Option<f64>,
    /// Mean number of pairs in contact per frame: `contact_frames / frames` (0 without frames).
    pub mean_pairs_in_contact: f64,
}

/// Counts contacts between agents (paper 000 Fig. 7: "collision statistics in a dense
/// setting", where the bee model's repulsion force is claimed to reduce agent–agent
/// collisions compared with the curl-noise model).
///
/// Two agents are in contact in a frame when their centres are strictly closer than
/// `contact_distance` metres (for bodies of radius r, use 2r). Only positions are used.
/// A uniform grid of cells of side `contact_distance` makes each frame O(n) for a bounded
/// density (1,000 agents × 100 frames take milliseconds); the result is exact and
/// deterministic. A non-positive or non-finite `contact_distance` gives no contacts.
pub fn contacts(frames: &Frames, contact_distance: f32) -> Contacts {
    let d = contact_distance as f64;
    let mut out = Contacts::default();
    let mut prev: Vec<(u32, u32)> = Vec::new();
    for (f, pos) in frames.positions().iter().enumerate() {
        let pairs = close_pairs(pos, d);
        out.contact_frames += pairs.len() as u64;
        if f > 0 {
            out.new_contacts += count_not_in(&pairs, &prev);
        }
        prev = pairs;
    }
    if !frames.is_empty() {
        out.mean_pairs_in_contact = out.contact_frames as f64 / frames.len() as f64;
    }
    let agents = frames.agents();
    let duration = frames.duration();
    if agents > 0 && duration > 0.0 {
        out.new_per_agent_second = Some(2.0 * out.new_contacts as f64 / (agents as f64 * duration));
    }
    out
}

/// Number of elements of sorted `a` absent from sorted `b`.
fn count_not_in(a: &[(u32, u32)], b: &[(u32, u32)]) -> u64 {
    let mut j = 0;
    let mut n = 0;
    for x in a {
        while j < b.len() && b[j] < *x {
            j += 1;
        }
        if j >= b.len() || b[j] != *x {
            n += 1;
        }
    }
    n
}

// ---------------------------------------------------------------------------------------
// Fig. 9: alignment
// ---------------------------------------------------------------------------------------

/// How aligned a swarm's headings are (paper 000 Fig. 9).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Alignment {
    /// Polarisation of each frame, `|⟨v̂⟩|`: the length of the mean unit velocity over the
    /// agents moving faster than [`MIN_SPEED`]. 1 when all fly the same way, about 1/√n
    /// for n random headings. `None` for a frame in which no agent moves.
    pub polarisation_per_frame: Vec<Option<f64>>,
    /// Mean of the per-frame polarisation over the frames where it is defined.
    pub polarisation: Option<f64>,
    /// Nearest-neighbour heading agreement: the mean of `v̂_i · v̂_nn(i)` over all frames and
    /// agents, nn(i) being the agent nearest to i in that frame. In [−1, 1]: 1 for parallel
    /// neighbours, 0 for unrelated headings. Samples where i or its neighbour moves no faster
    /// than [`MIN_SPEED`] are skipped (a heading does not exist at rest).
    pub neighbour_agreement: Option<f64>,
    /// Number of (frame, agent) samples in `neighbour_agreement`.
    pub neighbour_samples: usize,
}

/// Measures the alignment of a swarm (paper 000 Fig. 9, Sec. VII "Comparisons with prior
/// art": boids "failed to generate low-aligned and inherently-noisy behaviors"; the bee
/// model, Brownian motion and curl noise are low-aligned).
///
/// - polarisation `φ(t) = |Σ_i v̂_i(t)| / n(t)` over the n(t) moving agents, averaged over
///   frames; a global order parameter (Vicsek et al. 1995).
/// - neighbour agreement `⟨v̂_i · v̂_nn(i)⟩` over frames and agents, a local one: a swarm of
///   locally aligned flocks heading different ways has low polarisation but high agreement.
///
/// Nearest neighbours are found with a uniform grid (O(n) per frame for a swarm filling its
/// bounding box), by position regardless of speed; ties go to the lower agent index.
pub fn alignment(frames: &Frames) -> Alignment {
    let mut out = Alignment::default();
    let mut agree_sum = 0.0;
    for (pos, vel) in frames.positions().iter().zip(frames.velocities()) {
        let dirs: Vec<Option<DVec3>> = vel.iter().map(|v| direction(*v)).collect();
        let (sum, moving) = dirs
            .iter()
            .flatten()
            .fold((DVec3::ZERO, 0usize), |(s, n), d| (s + *d, n + 1));
        out.polarisation_per_frame
            .push((moving > 0).then(|| sum.length() / moving as f64));
        if moving < 2 {
            continue;
        }
        for (i, nn) in nearest_neighbours(pos).into_iter().enumerate() {
            if let (Some(a), Some(Some(b))) = (dirs[i], nn.map(|j| dirs[j as usize])) {
                agree_sum += a.dot(b);
                out.neighbour_samples += 1;
            }
        }
    }
    out.polarisation = mean(out.polarisation_per_frame.iter().flatten().copied());
    if out.neighbour_samples > 0 {
        out.neighbour_agreement = Some(agree_sum / out.neighbour_samples as f64);
    }
    out
}

/// Unit vector of `v`, or `None` at or below [`MIN_SPEED`].
fn direction(v: Vec3) -> Option<DVec3> {
    let v = v.as_dvec3();
    let s = v.length();
    (s > MIN_SPEED).then(|| v / s)
}

fn mean(it: impl Iterator<Item = f64>) -> Option<f64> {
    let (s, n) = it.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    (n > 0).then(|| s / n as f64)
}

// ---------------------------------------------------------------------------------------
// Fig. 5: trajectory shape
// ---------------------------------------------------------------------------------------

/// Settings of [`trajectory_shape`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeOptions {
    /// Speeds (m/s) at or below this have no direction: no turn rate or angular
    /// acceleration there, and horizontal speeds at or below it no yaw. Default
    /// [`MIN_SPEED`].
    pub min_speed: f64,
    /// Yaw rates (rad/s) within ±`dead_band` have no curvature sign, so float noise on a
    /// straight path is not counted as zigzagging, and a yaw rate whose standard deviation
    /// is below it has no spectral peak. Default 0.01 rad/s (0.6°/s), far below the turn
    /// rates of insects (rad/s).
    pub dead_band: f64,
}

impl Default for ShapeOptions {
    fn default() -> Self {
        ShapeOptions {
            min_speed: MIN_SPEED,
            dead_band: 0.01,
        }
    }
}

/// A one-sided power spectrum: bin k is at `k · df` Hz, k = 0 … N/2.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Spectrum {
    /// Bin spacing, Hz: `fps / N` with N the (zero-padded) transform length.
    pub df: f64,
    /// Power spectral density per bin, (signal unit)²/Hz.
    pub power: Vec<f64>,
}

impl Spectrum {
    /// Frequency of bin `k`, Hz.
    pub fn frequency(&self, k: usize) -> f64 {
        k as f64 * self.df
    }
}

/// The trajectory shape of one agent (paper 000 Fig. 5).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AgentShape {
    /// Yaw rate between frames i and i+1, rad/s, positive counter-clockwise seen from above
    /// (a right-handed turn about +Y); see [`yaw_rates`]. 0 where the heading is undefined.
    pub yaw_rate: Vec<f64>,
    /// Number of samples of `yaw_rate` where the heading was undefined (set to 0).
    pub undefined_yaw: usize,
    /// Power spectrum of the yaw rate; see [`power_spectrum`].
    pub spectrum: Spectrum,
    /// Frequency of the spectrum's highest bin other than DC, Hz; `None` when the yaw rate
    /// barely varies (standard deviation below the dead band) or has fewer than 4 samples.
    pub peak_frequency: Option<f64>,
    /// Median of the turn rate ω (Eq. 16), rad/s.
    pub median_turn_rate: Option<f64>,
    /// Median of |ω̇| (Eq. 17), rad/s².
    pub median_angular_acceleration: Option<f64>,
    /// Sign changes of the horizontal path's curvature (of the yaw rate, outside the dead
    /// band) per second of track; 0 for a straight line, 2f for a zigzag of frequency f.
    pub zigzags_per_second: f64,
}

/// The trajectory shape of all agents of a swarm, with swarm-wide summaries.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TrajectoryShape {
    /// One entry per agent, in agent order.
    pub agents: Vec<AgentShape>,
    /// Median turn rate ω over all agents' samples, rad/s.
    pub median_turn_rate: Option<f64>,
    /// Median |ω̇| over all agents' samples, rad/s².
    pub median_angular_acceleration: Option<f64>,
    /// Median over agents of the yaw-rate peak frequency, Hz (agents without a peak left out).
    pub median_peak_frequency: Option<f64>,
    /// Mean over agents of the zigzags (curvature sign changes) per second.
    pub zigzags_per_second: Option<f64>,
}

/// Measures the shape of each agent's trajectory (paper 000 Fig. 5 and Sec. VII: the
/// oscillation model's path is regular, the curl-noise model's "chaotic but unsmooth ... with
/// an abrupt turn", the bee model's smooth yet noisy, with zigzags).
///
/// From each agent's velocities v_i (frames 1/fps apart):
/// - **yaw rate** `ψ̇_i = wrap(ψ_{i+1} − ψ_i) · fps`, ψ the horizontal heading
///   ([`yaw_rates`]); its Hann-windowed **power spectrum** ([`power_spectrum`]) and the
///   **peak frequency** excluding DC: the rhythm of the agent's weaving, if it has one;
/// - **turn rate** `ω_i = ∠(v_i, v_{i+1}) · fps`, the 3D angle (Eq. 16), rad/s; its median
///   is high for chaotic, abrupt paths;
/// - **angular acceleration** `|ω_{i+1} − ω_i| · fps` (Eq. 17 as a magnitude), rad/s²; its
///   median is high for unsmooth paths;
/// - **zigzags per second**: sign changes of the yaw rate (the curvature of the horizontal
///   path) per second of track ([`sign_changes`]).
///
/// Medians, not means, so a few abrupt turns do not dominate.
pub fn trajectory_shape(frames: &Frames, opts: &ShapeOptions) -> TrajectoryShape {
    let fps = frames.fps();
    let duration = frames.duration();
    let mut all_omega = Vec::new();
    let mut all_alpha = Vec::new();
    let mut agents = Vec::with_capacity(frames.agents());
    for a in 0..frames.agents() {
        let v = frames.agent_velocities(a);
        let (yaw, undefined) = yaw_rates(&v, fps, opts.min_speed);
        let spectrum = power_spectrum(&yaw, fps);
        let peak_frequency = if std_dev(&yaw) >= opts.dead_band {
            peak_frequency(&spectrum)
        } else {
            None
        };
        let omega = turn_rates(&v, fps, opts.min_speed);
        let alpha: Vec<f64> = omega
            .windows(2)
            .filter_map(|w| match (w[0], w[1]) {
                (Some(a), Some(b)) => Some((b - a).abs() * fps),
                _ => None,
            })
            .collect();
        let omega: Vec<f64> = omega.into_iter().flatten().collect();
        let zigzags_per_second = if duration > 0.0 {
            sign_changes(&yaw, opts.dead_band) as f64 / duration
        } else {
            0.0
        };
        agents.push(AgentShape {
            median_turn_rate: median(omega.clone()),
            median_angular_acceleration: median(alpha.clone()),
            yaw_rate: yaw,
            undefined_yaw: undefined,
            spectrum,
            peak_frequency,
            zigzags_per_second,
        });
        all_omega.extend(omega);
        all_alpha.extend(alpha);
    }
    TrajectoryShape {
        median_turn_rate: median(all_omega),
        median_angular_acceleration: median(all_alpha),
        median_peak_frequency: median(agents.iter().filter_map(|s| s.peak_frequency).collect()),
        zigzags_per_second: if duration > 0.0 {
            mean(agents.iter().map(|s| s.zigzags_per_second))
        } else {
            None
        },
        agents,
    }
}

/// Yaw rate of a velocity series, rad/s, and the number of samples where it is undefined.
///
/// The heading is `ψ = atan2(−v_z, v_x)`: the angle of the horizontal velocity from +X,
/// positive counter-clockwise seen from above (+Y), i.e. right-handed about +Y. Sample i
/// (of `len − 1`) is `wrap(ψ_{i+1} − ψ_i) · fps` with wrap into (−π, π], which is the
/// derivative of the unwrapped heading as long as a frame turns less than half a turn.
/// Where either horizontal speed is at or below `min_speed` the heading is undefined and the
/// sample is 0 (no turning), so the series keeps one sample per frame step for the spectrum.
pub fn yaw_rates(velocities: &[Vec3], fps: f64, min_speed: f64) -> (Vec<f64>, usize) {
    let heading = |v: Vec3| {
        let (x, z) = (v.x as f64, v.z as f64);
        (x.hypot(z) > min_speed).then(|| (-z).atan2(x))
    };
    let mut undefined = 0;
    let rates = velocities
        .windows(2)
        .map(|w| match (heading(w[0]), heading(w[1])) {
            (Some(a), Some(b)) => wrap_angle(b - a) * fps,
            _ => {
                undefined += 1;
                0.0
            }
        })
        .collect();
    (rates, undefined)
}

/// Angle wrapped into (−π, π].
fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::{PI, TAU};
    let w = a.rem_euclid(TAU);
    if w > PI { w - TAU } else { w }
}

/// Turn rate ω_i = ∠(v_i, v_{i+1}) · fps, rad/s (paper 000 Eq. 16); `None` where either
/// speed is at or below `min_speed`.
pub fn turn_rates(velocities: &[Vec3], fps: f64, min_speed: f64) -> Vec<Option<f64>> {
    velocities
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0].as_dvec3(), w[1].as_dvec3());
            (a.length() > min_speed && b.length() > min_speed)
                .then(|| a.cross(b).length().atan2(a.dot(b)) * fps)
        })
        .collect()
}

/// Number of sign changes in `signal`, ignoring samples within ±`dead_band`: a change is
/// counted when a sample above the band follows one below it (or the reverse), with any
/// number of in-band samples between. Applied to the yaw rate, it counts the inflections of
/// the horizontal path.
pub fn sign_changes(signal: &[f64], dead_band: f64) -> usize {
    let mut last: Option<bool> = None;
    let mut n = 0;
    for &x in signal {
        if x.abs() <= dead_band {
            continue;
        }
        let pos = x > 0.0;
        if last.is_some_and(|l| l != pos) {
            n += 1;
        }
        last = Some(pos);
    }
    n
}

/// One-sided power spectral density of `signal` sampled at `fps`.
///
/// The mean is removed, a Hann window `w_n = sin²(π n / L)` applied (L the signal length),
/// the result zero-padded to the next power of two N ≥ L and transformed (radix-2 FFT).
/// Bin k (k = 0 … N/2) is at `k · fps / N` Hz with power `c_k |X_k|² / (fps Σ w_n²)`,
/// c_k = 2 except at DC and Nyquist where it is 1, so that summing bins times `df` gives
/// the windowed signal's variance: (signal unit)²/Hz. An empty signal gives no bins.
pub fn power_spectrum(signal: &[f64], fps: f64) -> Spectrum {
    let l = signal.len();
    if l == 0 {
        return Spectrum::default();
    }
    let n = l.next_power_of_two();
    let m = signal.iter().sum::<f64>() / l as f64;
    let mut re = vec![0.0; n];
    let mut im = vec![0.0; n];
    let mut wsum = 0.0;
    for (i, x) in signal.iter().enumerate() {
        let w = if l > 1 {
            (std::f64::consts::PI * i as f64 / l as f64).sin().powi(2)
        } else {
            1.0
        };
        wsum += w * w;
        re[i] = (x - m) * w;
    }
    fft(&mut re, &mut im);
    let scale = 1.0 / (fps * wsum.max(f64::MIN_POSITIVE));
    let power = (0..=n / 2)
        .map(|k| {
            let c = if k == 0 || k == n / 2 { 1.0 } else { 2.0 };
            c * (re[k] * re[k] + im[k] * im[k]) * scale
        })
        .collect();
    Spectrum {
        df: fps / n as f64,
        power,
    }
}

/// Frequency (Hz) of the highest bin other than DC (the lowest such bin on a tie); `None`
/// with fewer than 3 bins (a signal shorter than 4 samples) or when all of them are 0.
pub fn peak_frequency(s: &Spectrum) -> Option<f64> {
    if s.power.len() < 3 {
        return None;
    }
    let (k, p) =
        s.power.iter().enumerate().skip(1).fold(
            (0, 0.0),
            |(bk, bp), (k, &p)| if p > bp { (k, p) } else { (bk, bp) },
        );
    (p > 0.0).then(|| s.frequency(k))
}

/// In-place iterative radix-2 FFT (`X_k = Σ x_n e^{−2πi kn/N}`); the length must be a power
/// of two.
fn fft(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    debug_assert!(n.is_power_of_two() && im.len() == n);
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let ang = -std::f64::consts::TAU / len as f64;
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                let (s, c) = (ang * k as f64).sin_cos();
                let (a, b) = (start + k, start + k + len / 2);
                let tr = re[b] * c - im[b] * s;
                let ti = re[b] * s + im[b] * c;
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
            }
        }
        len <<= 1;
    }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let h = v.len() / 2;
    Some(if v.len() % 2 == 1 {
        v[h]
    } else {
        0.5 * (v[h - 1] + v[h])
    })
}

fn std_dev(v: &[f64]) -> f64 {
    let Some(m) = mean(v.iter().copied()) else {
        return 0.0;
    };
    (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / v.len() as f64).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    /// splitmix64: deterministic uniform numbers in [0, 1).
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            (z ^ (z >> 31)) as f64 / (u64::MAX as f64 + 1.0)
        }
        fn range(&mut self, lo: f64, hi: f64) -> f32 {
            (lo + (hi - lo) * self.next()) as f32
        }
        fn point(&mut self, half: f64) -> Vec3 {
            Vec3::new(
                self.range(-half, half),
                self.range(-half, half),
                self.range(-half, half),
            )
        }
        /// Uniform on the unit sphere.
        fn unit(&mut self) -> Vec3 {
            let z = 2.0 * self.next() - 1.0;
            let a = TAU * self.next();
            let r = (1.0 - z * z).sqrt();
            Vec3::new((r * a.cos()) as f32, z as f32, (r * a.sin()) as f32)
        }
    }

    fn frames(fps: f64, positions: Vec<Vec<Vec3>>, velocities: Vec<Vec<Vec3>>) -> Frames {
        Frames::new(fps, positions, velocities).unwrap()
    }

    /// One agent per entry of `vel(t)`, positions integrated from nothing (unused).
    fn single(fps: f64, n: usize, vel: impl Fn(f64) -> Vec3) -> Frames {
        let v: Vec<Vec<Vec3>> = (0..n).map(|i| vec![vel(i as f64 / fps)]).collect();
        frames(fps, vec![vec![Vec3::ZERO]; n], v)
    }

    fn brute_pairs(p: &[Vec3], d: f64) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for i in 0..p.len() {
            for j in i + 1..p.len() {
                if p[i].as_dvec3().distance(p[j].as_dvec3()) < d {
                    out.push((i as u32, j as u32));
                }
            }
        }
        out
    }

    #[test]
    fn frames_reject_inconsistent_input() {
        let p = vec![vec![Vec3::ZERO; 2]; 3];
        assert!(Frames::new(0.0, p.clone(), p.clone()).is_err());
        assert!(Frames::new(f64::NAN, p.clone(), p.clone()).is_err());
        assert!(Frames::new(10.0, p.clone(), p[..2].to_vec()).is_err());
        let mut ragged = p.clone();
        ragged[1].push(Vec3::ONE);
        assert!(Frames::new(10.0, ragged.clone(), ragged).is_err());
        let mut nan = p.clone();
        nan[2][1].y = f32::NAN;
        assert!(Frames::new(10.0, p.clone(), nan).is_err());
        let f = Frames::new(10.0, p.clone(), p).unwrap();
        assert_eq!((f.len(), f.agents()), (3, 2));
        assert!((f.duration() - 0.2).abs() < 1e-12);
    }

    #[test]
    fn two_agents_touching_for_exactly_five_frames() {
        // Agent 1 moves along X through agent 0 at the origin: distance |5 − 0.5 f| m.
        // Below 1.2 m for f = 8..=12 (1.0, 0.5, 0, 0.5, 1.0): five frames, one contact.
        let fps = 10.0;
        let pos: Vec<Vec<Vec3>> = (0..20)
            .map(|f| vec![Vec3::ZERO, Vec3::new(5.0 - 0.5 * f as f32, 0.0, 0.0)])
            .collect();
        let vel = vec![vec![Vec3::ZERO, Vec3::new(-5.0, 0.0, 0.0)]; 20];
        let c = contacts(&frames(fps, pos, vel), 1.2);
        assert_eq!(c.contact_frames, 5);
        assert_eq!(c.new_contacts, 1);
        // 2 · 1 contact / (2 agents · 1.9 s).
        let rate = c.new_per_agent_second.unwrap();
        assert!((rate - 1.0 / 1.9).abs() < 1e-12, "{rate}");
        assert!((c.mean_pairs_in_contact - 0.25).abs() < 1e-12);
    }

    #[test]
    fn contact_distance_is_strict() {
        // Exactly 1 m apart: not closer than 1 m.
        let pos = vec![vec![Vec3::ZERO, Vec3::X]; 3];
        let vel = vec![vec![Vec3::ZERO; 2]; 3];
        let f = frames(10.0, pos, vel);
        assert_eq!(contacts(&f, 1.0).contact_frames, 0);
        assert_eq!(contacts(&f, 1.001).contact_frames, 3);
        assert_eq!(contacts(&f, 0.0).contact_frames, 0);
        assert_eq!(contacts(&f, -1.0).contact_frames, 0);
    }

    #[test]
    fn contacts_restart_and_first_frame_are_counted_right() {
        // Pair (0,1) in contact at frames 0,1, apart at 2, in contact again at 3,4.
        // Pair (1,2) in contact only at frame 4. Starts seen: frame 3 and frame 4 → 2.
        let near = Vec3::new(0.1, 0.0, 0.0);
        let far = Vec3::new(3.0, 0.0, 0.0);
        let a2_far = Vec3::new(0.0, 5.0, 0.0);
        let a2_near = near + Vec3::new(0.0, 0.1, 0.0);
        let pos = vec![
            vec![Vec3::ZERO, near, a2_far],
            vec![Vec3::ZERO, near, a2_far],
            vec![Vec3::ZERO, far, a2_far],
            vec![Vec3::ZERO, near, a2_far],
            vec![Vec3::ZERO, near, a2_near],
        ];
        let vel = vec![vec![Vec3::ZERO; 3]; 5];
        let c = contacts(&frames(2.0, pos, vel), 0.5);
        // Frame 4: (0,1), (1,2) and (0,2) (|a2_near| ≈ 0.141 m).
        assert_eq!(c.contact_frames, 2 + 1 + 3);
        assert_eq!(c.new_contacts, 3);
        let rate = c.new_per_agent_second.unwrap();
        assert!((rate - 2.0 * 3.0 / (3.0 * 2.0)).abs() < 1e-12);
    }

    #[test]
    fn contacts_match_brute_force_on_a_random_swarm() {
        // 1,000 agents in a 2 m cube around the origin (negative cells too), drifting
        // randomly for 8 frames.
        let mut rng = Rng(7);
        let n = 1000;
        let d = 0.12;
        let mut p: Vec<Vec3> = (0..n).map(|_| rng.point(1.0)).collect();
        let mut pos = Vec::new();
        for _ in 0..8 {
            pos.push(p.clone());
            for x in &mut p {
                *x += rng.point(0.03);
            }
        }
        let mut want_frames = 0;
        let mut want_new = 0;
        let mut prev: Vec<(u32, u32)> = Vec::new();
        for (f, frame) in pos.iter().enumerate() {
            let pairs = brute_pairs(frame, d);
            assert_eq!(close_pairs(frame, d), pairs, "frame {f}");
            want_frames += pairs.len() as u64;
            if f > 0 {
                want_new += pairs.iter().filter(|x| !prev.contains(x)).count() as u64;
            }
            prev = pairs;
        }
        let vel = vec![vec![Vec3::ZERO; n]; pos.len()];
        let c = contacts(&frames(25.0, pos, vel), d as f32);
        assert!(
            want_frames > 100 && want_new > 10,
            "{want_frames} {want_new}"
        );
        assert_eq!((c.contact_frames, c.new_contacts), (want_frames, want_new));
    }

    #[test]
    fn nearest_neighbours_match_brute_force() {
        let mut rng = Rng(3);
        // A dense cluster, a sparse cloud, a far outlier and an exact duplicate (a tie).
        let mut p: Vec<Vec3> = (0..300).map(|_| rng.point(0.1)).collect();
        p.extend((0..200).map(|_| rng.point(3.0)));
        p.push(Vec3::new(40.0, -20.0, 5.0));
        p.push(p[10]);
        p.push(p[10]);
        let got = nearest_neighbours(&p);
        for (i, g) in got.iter().enumerate() {
            let want = (0..p.len())
                .filter(|&j| j != i)
                .min_by(|&a, &b| {
                    let da = p[i].as_dvec3().distance_squared(p[a].as_dvec3());
                    let db = p[i].as_dvec3().distance_squared(p[b].as_dvec3());
                    da.total_cmp(&db).then(a.cmp(&b))
                })
                .unwrap();
            assert_eq!(*g, Some(want as u32), "point {i}");
        }
        assert_eq!(nearest_neighbours(&[Vec3::ONE]), vec![None]);
        assert_eq!(
            nearest_neighbours(&[Vec3::ONE; 3]),
            vec![Some(1), Some(0), Some(0)]
        );
    }

    #[test]
    fn parallel_agents_are_fully_aligned() {
        let mut rng = Rng(11);
        let v = Vec3::new(0.3, -0.1, 0.8);
        let pos: Vec<Vec<Vec3>> = (0..5)
            .map(|_| (0..200).map(|_| rng.point(2.0)).collect())
            .collect();
        // Speeds differ; directions do not.
        let vel: Vec<Vec<Vec3>> = (0..5)
            .map(|_| (0..200).map(|_| v * rng.range(0.5, 2.0)).collect())
            .collect();
        let a = alignment(&frames(10.0, pos, vel));
        assert!((a.polarisation.unwrap() - 1.0).abs() < 1e-6);
        assert!((a.neighbour_agreement.unwrap() - 1.0).abs() < 1e-6);
        assert_eq!(a.neighbour_samples, 5 * 200);
        assert_eq!(a.polarisation_per_frame.len(), 5);
    }

    #[test]
    fn random_headings_are_unaligned() {
        let mut rng = Rng(5);
        let n = 1000;
        let pos: Vec<Vec<Vec3>> = (0..5)
            .map(|_| (0..n).map(|_| rng.point(2.0)).collect())
            .collect();
        let vel: Vec<Vec<Vec3>> = (0..5)
            .map(|_| (0..n).map(|_| rng.unit() * 0.7).collect())
            .collect();
        let a = alignment(&frames(10.0, pos, vel));
        // |⟨v̂⟩| ≈ 1/√n ≈ 0.03; agreement has standard error ≈ 0.58/√5000 ≈ 0.008.
        let p = a.polarisation.unwrap();
        let g = a.neighbour_agreement.unwrap();
        assert!(p < 0.1, "{p}");
        assert!(g.abs() < 0.05, "{g}");
    }

    #[test]
    fn opposite_flocks_agree_locally_but_not_globally() {
        // Two far-apart flocks flying opposite ways: polarisation 0, neighbours agree.
        let mut rng = Rng(9);
        let mut pos = Vec::new();
        let mut vel = Vec::new();
        for _ in 0..50 {
            pos.push(rng.point(0.5));
            vel.push(Vec3::X);
        }
        for _ in 0..50 {
            pos.push(rng.point(0.5) + Vec3::new(0.0, 100.0, 0.0));
            vel.push(-Vec3::X);
        }
        let a = alignment(&frames(10.0, vec![pos], vec![vel]));
        assert!(a.polarisation.unwrap() < 1e-6);
        assert!((a.neighbour_agreement.unwrap() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn resting_agents_have_no_heading() {
        // Agent 1 rests between two agents flying opposite ways; agent 0's nearest is the
        // resting one (skipped), agent 2's nearest is also agent 1 (skipped); agent 1 has
        // no heading itself. Polarisation counts only the two moving agents: 0.
        let pos = vec![vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.5]];
        let vel = vec![vec![Vec3::Z, Vec3::ZERO, -Vec3::Z]];
        let a = alignment(&frames(10.0, pos, vel));
        assert_eq!(a.neighbour_samples, 0);
        assert_eq!(a.neighbour_agreement, None);
        assert!(a.polarisation.unwrap() < 1e-9);
        // A frame where nobody moves has no polarisation and is left out of the mean.
        let pos = vec![vec![Vec3::ZERO, Vec3::X]; 2];
        let vel = vec![vec![Vec3::ZERO; 2], vec![Vec3::Y; 2]];
        let a = alignment(&frames(10.0, pos, vel));
        assert_eq!(a.polarisation_per_frame[0], None);
        assert!((a.polarisation.unwrap() - 1.0).abs() < 1e-9);
    }

    #[test]
    fn fft_matches_a_plain_dft() {
        let mut rng = Rng(1);
        let x: Vec<f64> = (0..16).map(|_| rng.next() - 0.5).collect();
        let (mut re, mut im) = (x.clone(), vec![0.0; 16]);
        fft(&mut re, &mut im);
        for k in 0..16 {
            let (mut r, mut i) = (0.0, 0.0);
            for (n, v) in x.iter().enumerate() {
                let a = -TAU * (k * n) as f64 / 16.0;
                r += v * a.cos();
                i += v * a.sin();
            }
            assert!(
                (re[k] - r).abs() < 1e-12 && (im[k] - i).abs() < 1e-12,
                "bin {k}"
            );
        }
    }

    #[test]
    fn sine_spectrum_peaks_at_its_frequency_and_keeps_its_variance() {
        // 3 Hz at 64 fps over 256 samples: exactly bin 12, 12 whole cycles.
        let fps = 64.0;
        let amp = 0.8;
        let x: Vec<f64> = (0..256)
            .map(|i| 2.0 + amp * (TAU * 3.0 * i as f64 / fps).sin())
            .collect();
        let s = power_spectrum(&x, fps);
        assert_eq!(s.power.len(), 129);
        assert!((s.df - 0.25).abs() < 1e-12);
        assert_eq!(peak_frequency(&s), Some(3.0));
        // The offset 2 is removed; Σ P·df is the (window-weighted) variance amp²/2.
        assert!(s.power[0] < 1e-20);
        let var: f64 = s.power.iter().sum::<f64>() * s.df;
        assert!((var - amp * amp / 2.0).abs() < 1e-3 * amp * amp, "{var}");
        assert_eq!(peak_frequency(&power_spectrum(&[1.0; 10], fps)), None);
        assert_eq!(peak_frequency(&power_spectrum(&[1.0, 2.0], fps)), None);
    }

    #[test]
    fn sign_changes_ignore_the_dead_band() {
        let x = [0.5, 0.005, -0.005, 0.3, -0.2, 0.0, -0.4, 0.1];
        assert_eq!(sign_changes(&x, 0.01), 2);
        assert_eq!(sign_changes(&x, 0.0), 4);
        assert_eq!(sign_changes(&[], 0.01), 0);
    }

    #[test]
    fn sinusoidal_zigzag_has_its_frequency_and_two_inflections_per_cycle() {
        // x = v t, z = A sin(2π f t): the heading swings at f, the horizontal curvature
        // changes sign at every zero crossing of z, 2f times per second.
        let (fps, v, amp, f) = (100.0, 1.0, 0.05, 2.0);
        let t_end = 4.0;
        let n = (t_end * fps) as usize + 1;
        let fr = single(fps, n, |t| {
            Vec3::new(v as f32, 0.0, (amp * TAU * f * (TAU * f * t).cos()) as f32)
        });
        let s = trajectory_shape(&fr, &ShapeOptions::default());
        let a = &s.agents[0];
        assert_eq!(a.yaw_rate.len(), n - 1);
        assert_eq!(a.undefined_yaw, 0);
        let peak = a.peak_frequency.unwrap();
        assert!((peak - f).abs() <= a.spectrum.df, "{peak}");
        // Crossings at t = k/(2f), k = 1..2fT−1 inside the track: 15 over 4 s.
        let changes = sign_changes(&a.yaw_rate, 0.01);
        assert_eq!(changes, (2.0 * f * t_end) as usize - 1);
        assert!((a.zigzags_per_second - 15.0 / t_end).abs() < 1e-9);
        assert!((s.zigzags_per_second.unwrap() - 15.0 / t_end).abs() < 1e-9);
        assert_eq!(s.median_peak_frequency, Some(peak));
        // Heading ψ = −atan(vz/vx) rises while vz falls: positive yaw rate at the start.
        assert!(a.yaw_rate[0] > 0.0);
    }

    #[test]
    fn helix_turns_steadily_without_zigzag_or_peak() {
        // Horizontal circle at ω rad/s, climbing: heading ψ = ω t (counter-clockwise from
        // above) with v = (s cos ωt, c, −s sin ωt).
        let (fps, w, s, c) = (50.0, 1.5, 1.0, 0.5);
        let fr = single(fps, 300, |t| {
            Vec3::new((s * (w * t).cos()) as f32, c, (-s * (w * t).sin()) as f32)
        });
        let shape = trajectory_shape(&fr, &ShapeOptions::default());
        let a = &shape.agents[0];
        for (i, r) in a.yaw_rate.iter().enumerate() {
            assert!((r - w).abs() < 1e-3, "sample {i}: {r}");
        }
        assert_eq!(a.peak_frequency, None);
        assert_eq!(a.zigzags_per_second, 0.0);
        // 3D angle between successive velocities: 2 asin(cos θ sin(ω dt / 2)) per frame.
        let cos_elev = s / (s * s + c as f64 * c as f64).sqrt();
        let want = 2.0 * (cos_elev * (w / fps / 2.0).sin()).asin() * fps;
        let got = shape.median_turn_rate.unwrap();
        assert!((got - want).abs() < 1e-3, "{got} vs {want}");
        assert!(shape.median_angular_acceleration.unwrap() < 0.2);
        // Mirrored (clockwise from above): the yaw rate changes sign.
        let mirror = single(fps, 300, |t| {
            Vec3::new((s * (w * t).cos()) as f32, c, (s * (w * t).sin()) as f32)
        });
        let m = trajectory_shape(&mirror, &ShapeOptions::default());
        assert!((m.agents[0].yaw_rate[7] + w).abs() < 1e-3);
    }

    #[test]
    fn straight_line_has_no_turning() {
        let fr = single(30.0, 120, |_| Vec3::new(0.4, 0.1, -0.3));
        let s = trajectory_shape(&fr, &ShapeOptions::default());
        let a = &s.agents[0];
        assert_eq!(a.zigzags_per_second, 0.0);
        assert_eq!(a.peak_frequency, None);
        assert_eq!(s.median_turn_rate, Some(0.0));
        assert_eq!(s.median_angular_acceleration, Some(0.0));
        assert!(a.yaw_rate.iter().all(|r| *r == 0.0));
    }

    #[test]
    fn abrupt_turns_show_in_turn_and_angular_acceleration_peaks() {
        // A smooth weave versus a path that flips between headings ±0.3 rad every 10
        // frames. The weave turns a little all the time; the flips turn 0.6 rad within one
        // frame (30 rad/s at 50 fps) and not at all in between, so their medians are 0 and
        // only the extremes show them: medians describe the typical flight, not rare events.
        let fps = 50.0;
        let smooth = single(fps, 200, |t| {
            let h = 0.3 * (TAU * t).sin();
            Vec3::new(h.cos() as f32, 0.0, h.sin() as f32)
        });
        let abrupt = single(fps, 200, |t| {
            let k = (t * fps).round() as i64;
            let h: f64 = if (k / 10) % 2 == 0 { 0.3 } else { -0.3 };
            Vec3::new(h.cos() as f32, 0.0, h.sin() as f32)
        });
        let o = ShapeOptions::default();
        let (s, a) = (trajectory_shape(&smooth, &o), trajectory_shape(&abrupt, &o));
        let omega = |f: &Frames| -> Vec<f64> {
            turn_rates(&f.agent_velocities(0), fps, MIN_SPEED)
                .into_iter()
                .flatten()
                .collect()
        };
        let max = |v: Vec<f64>| v.into_iter().fold(0.0, f64::max);
        // Smooth: |ω| ≤ 0.3 · 2π ≈ 1.9 rad/s everywhere.
        assert!(max(omega(&smooth)) < 2.0);
        assert!((max(omega(&abrupt)) - 0.6 * fps).abs() < 1e-3);
        assert_eq!(a.median_turn_rate, Some(0.0));
        assert_eq!(a.median_angular_acceleration, Some(0.0));
        assert!(s.median_turn_rate.unwrap() > 0.5);
        assert!(s.median_angular_acceleration.unwrap() > 1.0);
        // The flips are a zigzag too: 19 heading switches in 199 frame steps.
        let flips = sign_changes(&a.agents[0].yaw_rate, o.dead_band);
        assert_eq!(flips, 18);
    }

    #[test]
    fn a_thousand_agents_for_a_hundred_frames() {
        // The size the brief asks to stay fast with; dense enough to have contacts.
        let mut rng = Rng(13);
        let n = 1000;
        let mut p: Vec<Vec3> = (0..n).map(|_| rng.point(1.5)).collect();
        let v: Vec<Vec3> = (0..n).map(|_| rng.unit()).collect();
        let (mut pos, mut vel) = (Vec::new(), Vec::new());
        for _ in 0..100 {
            pos.push(p.clone());
            vel.push(v.clone());
            for (x, u) in p.iter_mut().zip(&v) {
                *x += *u * 0.02;
            }
        }
        let fr = frames(50.0, pos, vel);
        let c = contacts(&fr, 0.05);
        assert!(c.contact_frames > 0 && c.new_contacts > 0);
        let a = alignment(&fr);
        assert_eq!(a.neighbour_samples, n * 100);
        let s = trajectory_shape(&fr, &ShapeOptions::default());
        assert_eq!(s.agents.len(), n);
        assert_eq!(s.median_turn_rate, Some(0.0));
    }

    #[test]
    fn headings_are_undefined_when_hovering() {
        // Climbing straight up: no horizontal heading, yaw 0 and counted undefined.
        let fr = single(10.0, 5, |_| Vec3::Y);
        let s = trajectory_shape(&fr, &ShapeOptions::default());
        assert_eq!(s.agents[0].undefined_yaw, 4);
        assert_eq!(s.agents[0].median_turn_rate, Some(0.0));
        // At rest nothing is defined.
        let fr = single(10.0, 5, |_| Vec3::ZERO);
        let s = trajectory_shape(&fr, &ShapeOptions::default());
        assert_eq!(s.median_turn_rate, None);
        assert_eq!(s.median_angular_acceleration, None);
        // A single frame has no duration: no zigzag rate.
        let fr = single(10.0, 1, |_| Vec3::X);
        assert_eq!(
            trajectory_shape(&fr, &ShapeOptions::default()).zigzags_per_second,
            None
        );
    }
}
