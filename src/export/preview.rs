//! The bake preview: `<shot name>.preview.png`, a top view (X–Z) and a side view (X–Y) of
//! the trajectories with the shot's obstacles and targets, for checking a shot at a
//! glance without opening a 3D package.
//!
//! Layers, bottom to top: the ground (planes), the solid obstacles (filled, so a hive box
//! stands out), the paths (semi-transparent, so dense swarms show where they fly most),
//! each path's start (ring) and end (dot), then the targets with their names.
//!
//! Memory stays bounded whatever the shot: at most `MAX_BEES` bees are followed (an even
//! stride through all of them, chosen once so every trajectory is whole) and at most
//! `MAX_POINTS` positions per bee (every frame for shots up to that length, an even
//! stride of frames beyond).

use super::CacheWriter;
use crate::atomic::{AtomicFile, SealedFile};
use crate::error::{Error, Result};
use crate::plot::{
    Area, DrawResult, Figure, Legend, Mark, bold, house_axes, palette, px, text, tick_label,
};
use crate::shot::{Obstacle, Shape, Shot, Target, TargetKind};
use crate::sim::{CacheMeta, Frame};
use glam::Vec3;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::io::Write;
use std::path::{Path, PathBuf};

pub const MAX_BEES: usize = 300;
pub const MAX_POINTS: usize = 4000;

/// Layout in output pixels: figure width, margins, the side of each square plot area, the
/// panel caption strip, and the space for tick labels below and left of a plot.
const WIDTH: f64 = 1320.0;
const MARGIN: f64 = 16.0;
const PLOT: f64 = 560.0;
const CAPTION: f64 = 30.0;
const X_LABELS: f64 = 46.0;
const Y_LABELS: f64 = 64.0;

/// The ground lets the grid show through; solids hide it more.
const GROUND: RGBAColor = RGBAColor(222, 212, 178, 0.6);
const GROUND_EDGE: RGBColor = RGBColor(140, 128, 96);
const SOLID: RGBAColor = RGBAColor(80, 80, 88, 0.55);
const SOLID_EDGE: RGBColor = RGBColor(55, 55, 60);
const TARGET: RGBColor = RGBColor(190, 30, 30);

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

/// One of the two views: which way it looks and the data range it shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    pub top: bool,
    /// Shown ranges of the view's horizontal and vertical data axes, m. The top view's
    /// vertical axis is −z (so +z points down the image, as seen from above).
    pub x: (f64, f64),
    pub y: (f64, f64),
    /// The plot area in output pixels: left, top, side.
    pub origin: (f64, f64),
    pub side: f64,
}

impl View {
    /// The view's 2D data coordinates of a point: (x, −z) from above, (x, y) from the side.
    pub fn flat(&self, p: Vec3) -> (f64, f64) {
        if self.top {
            (p.x as f64, -p.z as f64)
        } else {
            (p.x as f64, p.y as f64)
        }
    }
    /// Where a point lands in the figure, output pixels.
    pub fn pixel(&self, p: Vec3) -> (f64, f64) {
        let (x, y) = self.flat(p);
        (
            self.origin.0 + (x - self.x.0) / (self.x.1 - self.x.0) * self.side,
            self.origin.1 + (self.y.1 - y) / (self.y.1 - self.y.0) * self.side,
        )
    }
    /// The direction the viewer looks in.
    fn looking(&self) -> Vec3 {
        if self.top { Vec3::NEG_Y } else { Vec3::NEG_Z }
    }
    /// Metres to output pixels.
    fn scale(&self) -> f64 {
        self.side / (self.x.1 - self.x.0)
    }
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
    pub fn render(&self) -> Result<Figure> {
        Ok(self.render_views()?.0)
    }

    /// Renders the figure and returns where its two views are, top view first.
    pub fn render_views(&self) -> Result<(Figure, [View; 2])> {
        let legend = self.legend();
        // The legend's height decides where the panels start; it is measured with the
        // same font on a scratch figure, so the layout fits whatever the names are.
        let mut legend_h = 0.0;
        Figure::draw(8, 8, |a| {
            legend_h = legend.height(a, WIDTH - 2.0 * MARGIN)?;
            Ok(())
        })?;
        let panel_y = MARGIN + 34.0 + legend_h + 12.0;
        let panel_w = WIDTH / 2.0;
        let height = panel_y + CAPTION + PLOT + X_LABELS + MARGIN;

        // Both views share the x range and the scale, so they line up and metres are
        // square on screen.
        let (lo, hi) = self.extent();
        let span = (hi - lo).max(Vec3::splat(1e-3));
        let side = (span.x.max(span.y).max(span.z) * 1.1) as f64;
        let mid = (lo + hi) * 0.5;
        let range = |m: f32| (m as f64 - side / 2.0, m as f64 + side / 2.0);
        let view = |top: bool, k: f64| View {
            top,
            x: range(mid.x),
            y: if top { range(-mid.z) } else { range(mid.y) },
            origin: (k * panel_w + Y_LABELS + MARGIN, panel_y + CAPTION),
            side: PLOT,
        };
        let views = [view(true, 0.0), view(false, 1.0)];

        let (f0, f1) = self.frame_range;
        let title = format!(
            "{}: {} bees ({} drawn), {} frames ({f0}–{f1} at {} fps)",
            self.shot_name,
            self.bee_total,
            self.followed.len(),
            self.frames_seen,
            self.fps
        );
        let fig = Figure::draw(WIDTH as u32, height.ceil() as u32, |root| {
            root.draw_text(&title, &bold(20.0, palette::TEXT), (px(MARGIN), px(MARGIN)))?;
            legend.draw(root, MARGIN, MARGIN + 34.0, WIDTH - 2.0 * MARGIN)?;
            for v in &views {
                self.draw_view(root, v)?;
            }
            Ok(())
        })?;
        Ok((fig, views))
    }

    fn legend(&self) -> Legend {
        let mut legend = Legend::default();
        for (i, n) in self.swarm_names.iter().enumerate() {
            legend.add(n.clone(), Mark::Line(palette::series(i).mix(0.8)));
        }
        legend.add("start", Mark::Ring(palette::TEXT));
        legend.add("end", Mark::Dot(palette::TEXT));
        let named = |planes: bool| -> Vec<&Obstacle> {
            let is_plane = |o: &&Obstacle| matches!(o.shape, Shape::Plane { .. });
            self.obstacles
                .iter()
                .filter(|o| is_plane(o) == planes)
                .collect()
        };
        for (planes, fill, edge, what) in [
            (true, GROUND, GROUND_EDGE, "planes"),
            (false, SOLID, SOLID_EDGE, "obstacles"),
        ] {
            let list = named(planes);
            // A few obstacles are named; a field of stems is one entry.
            if list.len() <= 4 {
                for o in list {
                    let moving = if o.keys.is_empty() { "" } else { ", swept" };
                    legend.add(
                        format!("{} ({}{moving})", o.name, shape_name(&o.shape)),
                        Mark::Area { fill, edge },
                    );
                }
            } else {
                legend.add(format!("{} {what}", list.len()), Mark::Area { fill, edge });
            }
        }
        if !self.targets.is_empty() {
            legend.add("targets", Mark::Dot(TARGET));
        }
        legend
    }

    fn draw_view(&self, root: &Area, v: &View) -> DrawResult {
        let (left, top) = v.origin;
        let caption = if v.top {
            "top view (looking down −y)"
        } else {
            "side view (looking along −z)"
        };
        root.draw_text(
            caption,
            &bold(16.0, palette::TEXT).pos(Pos::new(HPos::Center, VPos::Top)),
            (px(left + PLOT / 2.0), px(top - CAPTION + 4.0)),
        )?;
        let area = root.margin(px(top), px(0.0), px(left - Y_LABELS), px(0.0));
        let area = area.shrink((0, 0), (px(Y_LABELS + PLOT), px(PLOT + X_LABELS)));
        let mut chart = ChartBuilder::on(&area)
            .x_label_area_size(px(X_LABELS))
            .y_label_area_size(px(Y_LABELS))
            .build_cartesian_2d(v.x.0..v.x.1, v.y.0..v.y.1)?;
        let flip = |y: &f64| tick_label(if v.top { -*y } else { *y });
        house_axes(&mut chart.configure_mesh(), 13.0)
            .x_desc("x (m)")
            .y_desc(if v.top { "z (m)" } else { "y (m)" })
            .y_label_formatter(&flip)
            // A lighter grid under the paths.
            .bold_line_style(palette::GRID.mix(0.8).stroke_width(px(1.0) as u32))
            .x_labels(7)
            .y_labels(7)
            .draw()?;
        // The chart clips what it draws to the plot area: the ground's half-planes and
        // paths that leave the view are cut at the frame.
        self.draw_ground(&mut chart, v)?;
        self.draw_solids(&mut chart, v)?;
        self.draw_paths(&mut chart, v)?;
        self.draw_targets(&mut chart, v)
    }

    fn extent(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        let pts = self.paths.iter().flatten().copied();
        let tg = self.targets.iter().flat_map(|t| t.keys.iter().map(|k| k.1));
        // Solid obstacles are in the frame too (a hive the bees never reach still shows),
        // planes are not: they are unbounded.
        let solids = self.obstacles.iter().flat_map(swept_outline);
        for p in pts.chain(tg).chain(solids) {
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

    fn draw_ground(&self, chart: &mut Chart2d, v: &View) -> DrawResult {
        let rect = [
            (v.x.0, v.y.0),
            (v.x.1, v.y.0),
            (v.x.1, v.y.1),
            (v.x.0, v.y.1),
        ];
        // Every fill first, then the surface lines, so a wall's fill never veils the
        // line of another (the six planes of a cage).
        let mut lines = Vec::new();
        for o in &self.obstacles {
            let Shape::Plane { point, normal } = o.shape else {
                continue;
            };
            let facing = normal.dot(-v.looking());
            if facing.abs() > 1e-3 {
                // Seen face-on: the ground under a top view, a back wall behind a side view.
                // A plane seen from its solid side is in front of everything: left out.
                if facing > 0.0 {
                    chart.draw_series([Polygon::new(rect.to_vec(), GROUND.filled())])?;
                }
                continue;
            }
            // Edge-on: fill the solid side and draw the surface line.
            let (p, n) = (v.flat(point), v.flat(normal));
            let solid = clip_half_plane(&rect, p, n);
            if solid.len() >= 3 {
                chart.draw_series([Polygon::new(solid, GROUND.filled())])?;
            }
            let along = (-n.1, n.0);
            let far = (v.x.1 - v.x.0) * 4.0;
            lines.push(PathElement::new(
                vec![
                    (p.0 - along.0 * far, p.1 - along.1 * far),
                    (p.0 + along.0 * far, p.1 + along.1 * far),
                ],
                GROUND_EDGE.stroke_width(px(1.5) as u32),
            ));
        }
        chart.draw_series(lines)?;
        Ok(())
    }

    fn draw_solids(&self, chart: &mut Chart2d, v: &View) -> DrawResult {
        for o in &self.obstacles {
            let hull = convex_hull(swept_outline(o).into_iter().map(|p| v.flat(p)).collect());
            if hull.len() < 3 {
                continue;
            }
            let mut ring = hull.clone();
            ring.push(hull[0]);
            chart.draw_series([Polygon::new(hull, SOLID.filled())])?;
            chart.draw_series([PathElement::new(
                ring,
                SOLID_EDGE.stroke_width(px(1.5) as u32),
            )])?;
        }
        Ok(())
    }

    fn draw_paths(&self, chart: &mut Chart2d, v: &View) -> DrawResult {
        // Fainter paths the more there are, so a dense swarm still shows its structure.
        let alpha = (2.4 / (self.followed.len().max(1) as f64).sqrt()).clamp(0.15, 0.8);
        for ((si, _), path) in self.followed.iter().zip(&self.paths) {
            let col = palette::series(*si);
            chart.draw_series([PathElement::new(
                path.iter().map(|p| v.flat(*p)).collect::<Vec<_>>(),
                col.mix(alpha).stroke_width(px(1.0) as u32),
            )])?;
        }
        for ((si, _), path) in self.followed.iter().zip(&self.paths) {
            let (Some(first), Some(last)) = (path.first(), path.last()) else {
                continue;
            };
            let col = palette::darken(palette::series(*si), 0.25);
            chart.draw_series([
                Circle::new(v.flat(*first), px(3.0), col.stroke_width(px(1.2) as u32)),
                Circle::new(v.flat(*last), px(2.2), col.filled()),
            ])?;
        }
        Ok(())
    }

    fn draw_targets(&self, chart: &mut Chart2d, v: &View) -> DrawResult {
        for t in &self.targets {
            let pts: Vec<(f64, f64)> = t.keys.iter().map(|k| v.flat(k.1)).collect();
            let at = pts[0];
            chart.draw_series([PathElement::new(pts, TARGET.stroke_width(px(1.5) as u32))])?;
            chart.draw_series([Circle::new(at, px(4.0), TARGET.filled())])?;
            if t.kind == TargetKind::Surface {
                // A landing surface is a plane: drawn edge-on like a plane obstacle.
                if v.looking().dot(t.normal).abs() < 1e-3 {
                    let n = v.flat(t.normal);
                    let far = (v.x.1 - v.x.0) * 4.0;
                    chart.draw_series([PathElement::new(
                        vec![
                            (at.0 + n.1 * far, at.1 - n.0 * far),
                            (at.0 - n.1 * far, at.1 + n.0 * far),
                        ],
                        TARGET.stroke_width(px(1.5) as u32),
                    )])?;
                }
            } else {
                let r = (t.radius as f64 * v.scale()).max(5.0);
                chart.draw_series([Circle::new(at, px(r), TARGET.stroke_width(px(1.5) as u32))])?;
            }
            // The name beside the target's circle, on a veil so paths do not garble it.
            let style = text(14.0, TARGET).pos(Pos::new(HPos::Left, VPos::Center));
            let (tw, th) = chart.plotting_area().estimate_text_size(&t.name, &style)?;
            let dx = px((t.radius as f64 * v.scale()).max(5.0) + 5.0);
            let (tw, th) = (tw as i32, th as i32);
            chart.draw_series([EmptyElement::at(at)
                + Rectangle::new(
                    [
                        (dx - px(2.0), -th / 2 - px(2.0)),
                        (dx + tw + px(2.0), th / 2 + px(2.0)),
                    ],
                    palette::WHITE.mix(0.8).filled(),
                )
                + Text::new(t.name.clone(), (dx, 0), style)])?;
        }
        Ok(())
    }
}

type Chart2d<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn shape_name(s: &Shape) -> &'static str {
    match s {
        Shape::Sphere { .. } => "sphere",
        Shape::Box { .. } => "box",
        Shape::Capsule { .. } => "capsule",
        Shape::Cylinder { .. } => "cylinder",
        Shape::Plane { .. } => "plane",
        Shape::Mesh { .. } => "mesh",
    }
}

/// Points whose convex hull, seen from any direction, is the outline of a solid: box
/// corners, cylinder rims, and circles around each sphere (capsule end) in the three
/// coordinate planes, the outline of a sphere seen along an axis. Empty for a plane.
fn outline(s: &Shape) -> Vec<Vec3> {
    const N: usize = 48;
    let circle = |c: Vec3, r: f32, u: Vec3, w: Vec3| {
        (0..N).map(move |k| {
            let a = k as f32 / N as f32 * std::f32::consts::TAU;
            c + (u * a.cos() + w * a.sin()) * r
        })
    };
    let ball = |c: Vec3, r: f32| {
        circle(c, r, Vec3::X, Vec3::Y)
            .chain(circle(c, r, Vec3::X, Vec3::Z))
            .chain(circle(c, r, Vec3::Y, Vec3::Z))
            .collect::<Vec<_>>()
    };
    match *s {
        Shape::Sphere { center, radius } => ball(center, radius),
        Shape::Box {
            center,
            half,
            rotation,
        } => (0..8)
            .map(|i| {
                let s = Vec3::new(
                    if i & 1 == 0 { -1.0 } else { 1.0 },
                    if i & 2 == 0 { -1.0 } else { 1.0 },
                    if i & 4 == 0 { -1.0 } else { 1.0 },
                );
                center + rotation * (half * s)
            })
            .collect(),
        Shape::Capsule { a, b, radius } => {
            let mut pts = ball(a, radius);
            pts.extend(ball(b, radius));
            pts
        }
        Shape::Cylinder {
            center,
            radius,
            half_height,
            rotation,
        } => {
            let (u, w, up) = (rotation * Vec3::X, rotation * Vec3::Z, rotation * Vec3::Y);
            circle(center + up * half_height, radius, u, w)
                .chain(circle(center - up * half_height, radius, u, w))
                .collect()
        }
        Shape::Plane { .. } => Vec::new(),
        // The vertices (of a large mesh every k-th triangle's, enough for its outline at
        // preview size).
        Shape::Mesh { ref mesh, pose } => {
            let stride = mesh.triangle_count().div_ceil(20_000).max(1);
            let place = |p: Vec3| pose.map_or(p, |r| r.to_world(p));
            mesh.triangles()
                .step_by(stride)
                .flatten()
                .map(place)
                .collect()
        }
    }
}

/// The outline of an obstacle over the shot: a moving mesh's at every key (the hull of
/// them is the area it sweeps, near enough for keys close together), else its outline.
fn swept_outline(o: &Obstacle) -> Vec<Vec3> {
    match &o.shape {
        Shape::Mesh {
            mesh,
            pose: Some(_),
        } => o
            .keys
            .iter()
            .flat_map(|&(frame, _)| {
                outline(&Shape::Mesh {
                    mesh: mesh.clone(),
                    pose: o.pose_at(frame),
                })
            })
            .collect(),
        shape => outline(shape),
    }
}

/// Convex hull (Andrew's monotone chain), counter-clockwise, without repeated points.
fn convex_hull(mut pts: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    pts.retain(|p| p.0.is_finite() && p.1.is_finite());
    pts.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| {
        (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0)
    };
    let mut hull: Vec<(f64, f64)> = Vec::with_capacity(pts.len() * 2);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// The part of polygon `poly` where (q − p)·n ≤ 0 (Sutherland–Hodgman, one edge).
fn clip_half_plane(poly: &[(f64, f64)], p: (f64, f64), n: (f64, f64)) -> Vec<(f64, f64)> {
    let side = |q: (f64, f64)| (q.0 - p.0) * n.0 + (q.1 - p.1) * n.1;
    let mut out = Vec::with_capacity(poly.len() + 1);
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (sa, sb) = (side(a), side(b));
        if sa <= 0.0 {
            out.push(a);
        }
        if (sa < 0.0 && sb > 0.0) || (sa > 0.0 && sb < 0.0) {
            let t = sa / (sa - sb);
            out.push((a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t));
        }
    }
    out
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
        let bytes = self.render()?.encode_png()?;
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
    fn obstacles_are_filled_over_the_ground() {
        let dir = tempfile::tempdir().unwrap();
        let shot = crate::shot::parse(SHOT, Path::new("tiny.toml"), Path::new(".")).unwrap();
        let sim = Simulation::new(&shot);
        let w = PreviewWriter::create(&shot, &sim.meta(), dir.path()).unwrap();
        let (fig, [top, side]) = w.render_views().unwrap();
        let at = |v: &View, p: Vec3| {
            let (x, y) = v.pixel(p);
            fig.get(x as u32, y as u32).unwrap()
        };
        let lum = |c: [u8; 3]| c.iter().map(|&v| v as u32).sum::<u32>() / 3;
        // Seen from above, the ground (normal +y) covers the view; from the side it is
        // the half below y = 0.
        let tinted = |c: [u8; 3]| c[0] as i32 > c[2] as i32 + 20 && lum(c) < 240;
        let ground = at(&top, Vec3::new(top.x.0 as f32 + 0.05, 0.0, 0.0));
        assert!(tinted(ground), "{ground:?}");
        let below = at(&side, Vec3::new(side.x.0 as f32 + 0.05, -0.05, 0.0));
        assert!(tinted(below), "{below:?}");
        let above = at(&side, Vec3::new(side.x.0 as f32 + 0.05, 0.05, 0.0));
        assert!(!tinted(above) && lum(above) > 200, "{above:?}");
        // The box stands out against the ground in both views.
        for v in [&top, &side] {
            let b = at(v, Vec3::new(-0.5, 0.3, 0.0));
            assert!(lum(b) + 40 < lum(ground), "{b:?} vs {ground:?}");
        }
        // Both plot areas are squares of the same scale: 1 m is as long across as down.
        let (a, b) = (top.pixel(Vec3::ZERO), top.pixel(Vec3::new(1.0, 0.0, 1.0)));
        assert!(((b.0 - a.0) - (b.1 - a.1)).abs() < 1e-6 && b.0 > a.0);
        assert_eq!(top.x, side.x);
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
