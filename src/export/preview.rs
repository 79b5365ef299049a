//! The bake preview: `<shot name>.preview.png`, a top view (X–Z) and a side view (X–Y) of
//! the trajectories with the shot's obstacles and targets, for checking a shot at a
//! glance without opening a 3D package.
//!
//! Memory stays bounded whatever the shot: at most `MAX_BEES` bees are followed (an even
//! stride through all of them, chosen once so every trajectory is whole) and at most
//! `MAX_POINTS` positions per bee (every frame for shots up to that length, an even
//! stride of frames beyond).

use super::CacheWriter;
use crate::atomic::{AtomicFile, SealedFile};
use crate::error::{Error, Result};
use crate::plot::{Canvas, Chart, Legend, LegendMark, Rgb, palette};
use crate::shot::{Obstacle, Shape, Shot, Target, TargetKind};
use crate::sim::{CacheMeta, Frame};
use glam::Vec3;
use std::io::Write;
use std::path::{Path, PathBuf};

pub const MAX_BEES: usize = 300;
pub const MAX_POINTS: usize = 4000;

const PANEL: i64 = 620;
/// Smallest distance from the image top to the plot areas, px.
const MARGIN_TOP: i64 = 78;

pub struct PreviewWriter {
    path: PathBuf,
    shot_name: String,
    fps: f64,
    frame_range: (i32, i32),
    swarm_names: Vec<String>,
    obstacles: Vec<Obstacle>,
    targets: Vec<Target>,
    bee_total: usize,
    /// (swarm, index in swarm) of each followed bee.
    followed: Vec<(usize, usize)>,
    paths: Vec<Vec<Vec3>>,
    frame_stride: usize,
    frames_seen: usize,
}

impl PreviewWriter {
    pub fn create(shot: &Shot, meta: &CacheMeta, dir: &Path) -> Result<Self> {
        let total = shot.bee_count();
        let stride = total.div_ceil(MAX_BEES).max(1);
        let mut followed = Vec::new();
        let mut g = 0usize;
        for (si, s) in shot.swarms.iter().enumerate() {
            for i in 0..s.count {
                if g.is_multiple_of(stride) {
                    followed.push((si, i));
                }
                g += 1;
            }
        }
        let frames = meta.frame_count();
        Ok(PreviewWriter {
            path: dir.join(format!("{}.preview.png", meta.shot_name)),
            shot_name: meta.shot_name.clone(),
            fps: meta.fps,
            frame_range: (meta.frame_start, meta.frame_end),
            swarm_names: shot.swarms.iter().map(|s| s.name.clone()).collect(),
            obstacles: shot.obstacles.clone(),
            targets: shot.targets.clone(),
            bee_total: total,
            paths: vec![Vec::with_capacity(frames.min(MAX_POINTS)); followed.len()],
            followed,
            frame_stride: frames.div_ceil(MAX_POINTS).max(1),
            frames_seen: 0,
        })
    }

    /// Renders the figure (public so tests and tools can draw without a bake).
    pub fn render(&self) -> Canvas {
        let mut legend = Legend::default();
        for (i, n) in self.swarm_names.iter().enumerate() {
            legend.add(n.clone(), palette::series(i), LegendMark::Line);
        }
        if !self.obstacles.is_empty() {
            legend.add("obstacles", palette::GREY, LegendMark::Line);
        }
        if !self.targets.is_empty() {
            legend.add("targets", TARGET, LegendMark::Box);
        }
        let (_, lh) = legend.size();
        // Title, then the legend, then the two square plot areas side by side.
        let top_y = MARGIN_TOP.max(40 + lh + 30);
        let plot = PANEL - 90;
        let width = 2 * PANEL + 40;
        let height = top_y + plot + 50;
        let mut c = Canvas::new(width as u32, height as u32, palette::WHITE);
        let (f0, f1) = self.frame_range;
        let title = format!(
            "{}: {} bees ({} drawn), {} frames ({f0}-{f1} at {} fps)",
            self.shot_name,
            self.bee_total,
            self.followed.len(),
            self.frames_seen,
            self.fps
        );
        c.text(16, 10, &title, palette::BLACK, 2);
        legend.draw(&mut c, 16, 36);

        // Both views share the x range and the scale, so they line up and metres are
        // square on screen.
        let (lo, hi) = self.extent();
        let span = (hi - lo).max(Vec3::splat(1e-3));
        let side = span.x.max(span.y).max(span.z) * 1.1;
        let mid = (lo + hi) * 0.5;
        let range = |m: f32| ((m - side / 2.0) as f64, (m + side / 2.0) as f64);
        // Top view looks down −Y: +x right, +z towards the bottom of the image.
        let (zl, zh) = range(mid.z);
        let top = Chart::new(70, top_y, 70 + plot, top_y + plot, range(mid.x), (zh, zl));
        let sidev = Chart::new(
            PANEL + 110,
            top_y,
            PANEL + 110 + plot,
            top_y + plot,
            range(mid.x),
            range(mid.y),
        );
        for (chart, axis, name) in [
            (&top, 2usize, "top view (looking down)"),
            (&sidev, 1, "side view (looking along -z)"),
        ] {
            chart.frame(
                &mut c,
                name,
                "x (m)",
                if axis == 2 { "z (m)" } else { "y (m)" },
            );
            chart.clip(&mut c);
            self.draw_obstacles(&mut c, chart, axis);
            self.draw_paths(&mut c, chart, axis);
            self.draw_targets(&mut c, chart, axis);
            chart.unclip(&mut c);
        }
        c
    }

    fn extent(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        let pts = self.paths.iter().flatten().copied();
        let tg = self.targets.iter().flat_map(|t| t.keys.iter().map(|k| k.1));
        for p in pts.chain(tg) {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if !lo.is_finite() || !hi.is_finite() {
            // Nothing recorded (no frame yet): show a unit cube at the origin.
            (Vec3::ZERO, Vec3::ONE)
        } else {
            (lo, hi)
        }
    }

    fn draw_paths(&self, c: &mut Canvas, chart: &Chart, axis: usize) {
        for (k, ((si, _), path)) in self.followed.iter().zip(&self.paths).enumerate() {
            // Bees of a swarm share its colour, with a few shades so paths can be told apart.
            let shade = (k % 5) as f64 * 0.12;
            let col = palette::lighten(palette::series(*si), shade);
            let pts: Vec<(f64, f64)> = path
                .iter()
                .map(|p| chart.px(p.x as f64, view_y(*p, axis)))
                .collect();
            c.polyline(&pts, col, 1);
            if let Some(&(x, y)) = pts.last() {
                c.fill_circle(x, y, 2.0, palette::darken(palette::series(*si), 0.2));
            }
        }
    }

    fn draw_targets(&self, c: &mut Canvas, chart: &Chart, axis: usize) {
        let scale = (chart.right - chart.left) as f64 / (chart.x.1 - chart.x.0).abs();
        for t in &self.targets {
            let pts: Vec<(f64, f64)> = t
                .keys
                .iter()
                .map(|k| chart.px(k.1.x as f64, view_y(k.1, axis)))
                .collect();
            c.polyline(&pts, TARGET, 1);
            let (x, y) = pts[0];
            c.fill_circle(x, y, 4.0, TARGET);
            if t.kind == TargetKind::Surface {
                // A landing surface is a plane: drawn edge-on like a plane obstacle.
                if let Some((a, b)) = plane_edge(chart, axis, t.keys[0].1, t.normal) {
                    c.line(a.0, a.1, b.0, b.1, TARGET, 1);
                }
            } else {
                c.circle(x, y, t.radius as f64 * scale, TARGET);
            }
            c.text(x as i64 + 7, y as i64 - 12, &t.name, TARGET, 1);
        }
    }

    fn draw_obstacles(&self, c: &mut Canvas, chart: &Chart, axis: usize) {
        let scale = (chart.right - chart.left) as f64 / (chart.x.1 - chart.x.0).abs();
        let col = palette::GREY;
        let to = |p: Vec3| chart.px(p.x as f64, view_y(p, axis));
        for o in &self.obstacles {
            match o.shape {
                Shape::Sphere { center, radius } => {
                    let (x, y) = to(center);
                    c.circle(x, y, radius as f64 * scale, col);
                }
                Shape::Box {
                    center,
                    half,
                    rotation,
                } => {
                    let corner = |i: usize| {
                        let s = Vec3::new(
                            if i & 1 == 0 { -1.0 } else { 1.0 },
                            if i & 2 == 0 { -1.0 } else { 1.0 },
                            if i & 4 == 0 { -1.0 } else { 1.0 },
                        );
                        to(center + rotation * (half * s))
                    };
                    for a in 0..8 {
                        for bit in [1, 2, 4] {
                            if a & bit == 0 {
                                let (p, q) = (corner(a), corner(a | bit));
                                c.line(p.0, p.1, q.0, q.1, col, 1);
                            }
                        }
                    }
                }
                Shape::Capsule { a, b, radius } => {
                    let (pa, pb) = (to(a), to(b));
                    let r = radius as f64 * scale;
                    c.circle(pa.0, pa.1, r, col);
                    c.circle(pb.0, pb.1, r, col);
                    let (dx, dy) = (pb.0 - pa.0, pb.1 - pa.1);
                    let l = (dx * dx + dy * dy).sqrt();
                    if l > 1e-9 {
                        let (nx, ny) = (-dy / l * r, dx / l * r);
                        c.line(pa.0 + nx, pa.1 + ny, pb.0 + nx, pb.1 + ny, col, 1);
                        c.line(pa.0 - nx, pa.1 - ny, pb.0 - nx, pb.1 - ny, col, 1);
                    }
                }
                Shape::Cylinder {
                    center,
                    radius,
                    half_height,
                    rotation,
                } => {
                    let ring = |h: f32| -> Vec<(f64, f64)> {
                        (0..=32)
                            .map(|k| {
                                let a = k as f32 / 32.0 * std::f32::consts::TAU;
                                let local = Vec3::new(radius * a.cos(), h, radius * a.sin());
                                to(center + rotation * local)
                            })
                            .collect()
                    };
                    c.polyline(&ring(half_height), col, 1);
                    c.polyline(&ring(-half_height), col, 1);
                    for k in 0..4 {
                        let a = k as f32 * std::f32::consts::FRAC_PI_2;
                        let off = Vec3::new(radius * a.cos(), 0.0, radius * a.sin());
                        let p = to(center + rotation * (off + Vec3::Y * half_height));
                        let q = to(center + rotation * (off - Vec3::Y * half_height));
                        c.line(p.0, p.1, q.0, q.1, col, 1);
                    }
                }
                Shape::Plane { point, normal } => {
                    if let Some((p, q)) = plane_edge(chart, axis, point, normal) {
                        c.line(p.0, p.1, q.0, q.1, col, 2);
                    }
                }
                Shape::Mesh { mesh } => {
                    // A wireframe; of a large mesh every k-th triangle, enough to show
                    // its shape at preview size.
                    let stride = mesh.triangle_count().div_ceil(20_000).max(1);
                    for t in mesh.triangles().step_by(stride) {
                        let p: Vec<(f64, f64)> = [t[0], t[1], t[2], t[0]].map(to).to_vec();
                        c.polyline(&p, col, 1);
                    }
                }
            }
        }
    }
}

const TARGET: Rgb = [180, 30, 30];

/// The screen end points of a plane seen edge-on, or `None` when the view does not run
/// along it (then it covers the whole view or none of it).
fn plane_edge(
    chart: &Chart,
    axis: usize,
    point: Vec3,
    normal: Vec3,
) -> Option<((f64, f64), (f64, f64))> {
    // The view direction: −Y for the top view, −Z for the side view.
    let view = if axis == 2 { Vec3::Y } else { Vec3::Z };
    if normal.dot(view).abs() > 1e-3 {
        return None;
    }
    let along = normal.cross(view).normalize_or_zero();
    let far = (chart.x.1 - chart.x.0).abs() as f32 * 4.0;
    let to = |p: Vec3| chart.px(p.x as f64, view_y(p, axis));
    Some((to(point - along * far), to(point + along * far)))
}

/// The vertical screen coordinate of a view: z for the top view, y for the side view.
fn view_y(p: Vec3, axis: usize) -> f64 {
    if axis == 2 { p.z as f64 } else { p.y as f64 }
}

impl CacheWriter for PreviewWriter {
    fn write_frame(&mut self, frame: &Frame) -> Result<()> {
        let keep = self.frames_seen.is_multiple_of(self.frame_stride);
        self.frames_seen += 1;
        if !keep {
            return Ok(());
        }
        for ((si, i), path) in self.followed.iter().zip(&mut self.paths) {
            if let Some(p) = frame.swarms.get(*si).and_then(|s| s.position.get(*i)) {
                path.push(*p);
            }
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<Vec<SealedFile>> {
        // Sealed, not committed: the bake renames it with every other cache file.
        let bytes = self.render().encode_png()?;
        let mut f = AtomicFile::create(&self.path)?;
        f.write_all(&bytes).map_err(|e| Error::io(&self.path, e))?;
        Ok(vec![f.seal()?])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::Simulation;

    const SHOT: &str = r#"
[scene]
name = "tiny"
fps = 24
frames = [1, 30]
[[swarm]]
count = 7
[[obstacle]]
type = "sphere"
center = [0.3, 1.0, 0.0]
radius = 0.1
[[obstacle]]
type = "box"
center = [-0.5, 0.5, 0.0]
size = [0.2, 1.0, 0.2]
rotation = [0.0, 30.0, 0.0]
[[obstacle]]
type = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]
[[target]]
type = "flower"
name = "f"
keys = [{ frame = 1, position = [0.0, 1.2, 0.0] }, { frame = 30, position = [0.4, 1.2, 0.3] }]
"#;

    fn bake(dir: &Path) -> PathBuf {
        let shot = crate::shot::parse(SHOT, Path::new("tiny.toml"), Path::new(".")).unwrap();
        let mut sim = Simulation::new(&shot);
        let mut w: Box<dyn CacheWriter> =
            Box::new(PreviewWriter::create(&shot, &sim.meta(), dir).unwrap());
        for k in 0..shot.frame_count() {
            if k > 0 {
                sim.advance();
            }
            let frame = Frame {
                frame: sim.frame(),
                time: sim.time(),
                swarms: sim.record(),
            };
            w.write_frame(&frame).unwrap();
        }
        let out = crate::atomic::commit_all(w.finish().unwrap()).unwrap();
        assert_eq!(out.len(), 1);
        out[0].clone()
    }

    #[test]
    fn writes_the_same_png_every_time() {
        let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let (pa, pb) = (bake(a.path()), bake(b.path()));
        assert!(pa.ends_with("tiny.preview.png"));
        let bytes = std::fs::read(&pa).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        assert_eq!(bytes, std::fs::read(&pb).unwrap());
    }

    #[test]
    fn follows_a_bounded_even_subset_of_bees() {
        let src = SHOT.replace("count = 7", "count = 1000");
        let shot = crate::shot::parse(&src, Path::new("big.toml"), Path::new(".")).unwrap();
        let meta = Simulation::new(&shot).meta();
        let w = PreviewWriter::create(&shot, &meta, Path::new(".")).unwrap();
        assert!(w.followed.len() <= MAX_BEES && w.followed.len() >= MAX_BEES / 2);
        assert_eq!(w.followed[0], (0, 0));
    }
}
