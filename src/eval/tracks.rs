//! Trajectory data sets: our tracks CSV and recorded insect flights, read into tracks that
//! are continuous in time.
//!
//! Two formats are recognised by their header line:
//! - **beeswarm** tracks CSV (`id,frame,time,x,y,z,vx,vy,vz,...`, comma-separated), the
//!   output of `beeswarm bake` with the `csv` format;
//! - **splined** flight tracks (`object;time;XSplined;YSplined;ZSplined;VXSplined;...`,
//!   semicolon-separated) as in the mosquito recordings, where rows of `NaN` mark gaps.
//!
//! A track is split wherever its data is interrupted: a row with a non-finite value, a
//! change of id, or a time step more than 1.5 times the track's usual step. Metrics are
//! never computed across such a break, where they would report a jump that never happened.

use crate::error::{Error, Result};
use glam::DVec3;
use std::collections::HashMap;
use std::path::Path;

/// One uninterrupted trajectory: samples in increasing time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Track {
    /// Insect or segment id from the file; split pieces share it.
    pub id: String,
    /// Seconds.
    pub time: Vec<f64>,
    /// Metres.
    pub position: Vec<DVec3>,
    /// Metres per second.
    pub velocity: Vec<DVec3>,
}

impl Track {
    pub fn len(&self) -> usize {
        self.time.len()
    }
    pub fn is_empty(&self) -> bool {
        self.time.is_empty()
    }
    pub fn duration(&self) -> f64 {
        match (self.time.first(), self.time.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    }
    fn push(&mut self, t: f64, p: DVec3, v: DVec3) {
        self.time.push(t);
        self.position.push(p);
        self.velocity.push(v);
    }
}

/// The file formats `read` recognises.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TrackFormat {
    Beeswarm,
    Splined,
    /// Built in memory (calibration), not read from a file.
    Memory,
}

/// Part `i` of `n` of a data set, for held-out evaluation: its ids numbered 0, 1, 2, … in
/// the order they first appear, those numbered i mod n kept (`I/N` on the command line,
/// e.g. `0/2` the even-numbered recorded segments, `1/2` the odd ones).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Part {
    pub i: usize,
    pub n: usize,
}

impl std::str::FromStr for Part {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Part, String> {
        let bad = || format!("expected I/N with 0 ≤ I < N (e.g. 1/2), found `{s}`");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (i, n) = (i.trim().parse(), n.trim().parse());
        match (i, n) {
            (Ok(i), Ok(n)) if i < n => Ok(Part { i, n }),
            _ => Err(bad()),
        }
    }
}

impl std::fmt::Display for Part {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(f, "{}/{}", self.i, self.n)
    }
}

/// A named set of tracks.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    pub name: String,
    pub format: TrackFormat,
    pub tracks: Vec<Track>,
}

impl Dataset {
    pub fn sample_count(&self) -> usize {
        self.tracks.iter().map(Track::len).sum()
    }

    /// Only the tracks of part `p` (see [`Part`]); the name says which part.
    pub fn part(mut self, p: Part) -> Dataset {
        let mut rank: HashMap<String, usize> = HashMap::new();
        self.tracks.retain(|t| {
            let next = rank.len();
            *rank.entry(t.id.clone()).or_insert(next) % p.n == p.i
        });
        self.name = format!("{} (part {p})", self.name);
        self
    }

    /// Median time step over all tracks, seconds (0 when no track has two samples).
    pub fn median_step(&self) -> f64 {
        let mut steps: Vec<f64> = self
            .tracks
            .iter()
            .flat_map(|t| t.time.windows(2).map(|w| w[1] - w[0]))
            .filter(|s| *s > 0.0 && s.is_finite())
            .collect();
        if steps.is_empty() {
            return 0.0;
        }
        steps.sort_by(f64::total_cmp);
        steps[steps.len() / 2]
    }
}

/// Reads a tracks file, detecting its format from the header.
pub fn read(path: &Path) -> Result<Dataset> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::input(format!("cannot read tracks file {}: {e}", path.display())))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    parse(&text, &name).map_err(|e| Error::input(format!("{}: {e}", path.display())))
}

/// Column positions of the values a format provides.
struct Layout {
    format: TrackFormat,
    sep: char,
    id: usize,
    time: usize,
    pos: [usize; 3],
    vel: [usize; 3],
}

fn layout(header: &str) -> std::result::Result<Layout, String> {
    let sep = if header.contains(';') { ';' } else { ',' };
    let cols: Vec<String> = header
        .split(sep)
        .map(|c| c.trim().to_ascii_lowercase())
        .collect();
    let find = |name: &str| cols.iter().position(|c| c == name);
    let need = |name: &str| find(name).ok_or_else(|| format!("header has no `{name}` column"));
    if find("object").is_some() && find("xsplined").is_some() {
        Ok(Layout {
            format: TrackFormat::Splined,
            sep,
            id: need("object")?,
            time: need("time")?,
            pos: [need("xsplined")?, need("ysplined")?, need("zsplined")?],
            vel: [need("vxsplined")?, need("vysplined")?, need("vzsplined")?],
        })
    } else if find("id").is_some() && find("frame").is_some() {
        Ok(Layout {
            format: TrackFormat::Beeswarm,
            sep,
            id: need("id")?,
            time: need("time")?,
            pos: [need("x")?, need("y")?, need("z")?],
            vel: [need("vx")?, need("vy")?, need("vz")?],
        })
    } else {
        Err(format!(
            "unrecognised header `{}`: expected a beeswarm tracks CSV (id,frame,time,x,y,z,vx,vy,vz,...) \
             or splined flight tracks (object;time;XSplined;YSplined;ZSplined;VXSplined;VYSplined;VZSplined)",
            header.trim()
        ))
    }
}

/// One row: time, position, velocity; `None` for a gap marker (a non-finite row).
type Row = Option<(f64, DVec3, DVec3)>;

/// Parses tracks text (see the module docs for the formats).
pub fn parse(text: &str, name: &str) -> std::result::Result<Dataset, String> {
    let mut lines = text.lines().enumerate();
    let header = lines
        .by_ref()
        .find(|(_, l)| !l.trim().is_empty())
        .map(|(_, l)| l.trim_start_matches('\u{feff}'))
        .ok_or("the file is empty")?;
    let lay = layout(header)?;
    let ncols = lay
        .pos
        .iter()
        .chain(&lay.vel)
        .chain([&lay.id, &lay.time])
        .max()
        .copied()
        .unwrap_or(0)
        + 1;

    // Rows per id in file order. A non-finite row is kept as `None`: a gap marker.
    // Groups keep the order in which ids first appear, so track order follows the file.
    let mut index: HashMap<String, usize> = HashMap::new();
    let mut groups: Vec<(String, Vec<Row>)> = Vec::new();
    for (n, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(lay.sep).map(str::trim).collect();
        if f.len() < ncols {
            return Err(format!(
                "line {}: expected at least {ncols} fields, found {}",
                n + 1,
                f.len()
            ));
        }
        let num = |i: usize| -> std::result::Result<f64, String> {
            f[i].parse::<f64>().map_err(|_| {
                format!(
                    "line {}: field {} is not a number: `{}`",
                    n + 1,
                    i + 1,
                    f[i]
                )
            })
        };
        let g = match index.get(f[lay.id]) {
            Some(&g) => g,
            None => {
                index.insert(f[lay.id].to_owned(), groups.len());
                groups.push((f[lay.id].to_owned(), Vec::new()));
                groups.len() - 1
            }
        };
        let t = num(lay.time)?;
        let p = DVec3::new(num(lay.pos[0])?, num(lay.pos[1])?, num(lay.pos[2])?);
        let v = DVec3::new(num(lay.vel[0])?, num(lay.vel[1])?, num(lay.vel[2])?);
        let row = (t.is_finite() && p.is_finite() && v.is_finite()).then_some((t, p, v));
        groups[g].1.push(row);
    }

    let mut tracks = Vec::new();
    for (id, rs) in &groups {
        split_into(id, rs, &mut tracks);
    }
    Ok(Dataset {
        name: name.to_owned(),
        format: lay.format,
        tracks,
    })
}

/// Splits one id's rows at gap markers, time reversals and time gaps.
fn split_into(id: &str, rows: &[Row], out: &mut Vec<Track>) {
    let mut steps: Vec<f64> = rows
        .windows(2)
        .filter_map(|w| match (w[0], w[1]) {
            (Some(a), Some(b)) if b.0 > a.0 => Some(b.0 - a.0),
            _ => None,
        })
        .collect();
    steps.sort_by(f64::total_cmp);
    let usual = steps.get(steps.len() / 2).copied().unwrap_or(f64::INFINITY);
    let mut cur = Track {
        id: id.to_owned(),
        ..Default::default()
    };
    let flush = |cur: &mut Track, out: &mut Vec<Track>| {
        if !cur.is_empty() {
            out.push(std::mem::replace(
                cur,
                Track {
                    id: id.to_owned(),
                    ..Default::default()
                },
            ));
        }
    };
    for r in rows {
        match *r {
            None => flush(&mut cur, out),
            Some((t, p, v)) => {
                if let Some(&last) = cur.time.last()
                    && (t <= last || t - last > 1.5 * usual)
                {
                    flush(&mut cur, out);
                }
                cur.push(t, p, v);
            }
        }
    }
    flush(&mut cur, out);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splined_rows_split_at_nan_gaps() {
        let text = "object;time;XSplined;YSplined;ZSplined;VXSplined;VYSplined;VZSplined\n\
            1;0.00;0;0;0;1;0;0\n1;0.02;0.02;0;0;1;0;0\n1;NaN;NaN;NaN;NaN;NaN;NaN;NaN\n\
            1;0.10;0.1;0;0;1;0;0\n1;0.12;0.12;0;0;1;0;0\n1;0.14;0.14;0;0;1;0;0\n\
            2;0.00;5;0;0;0;1;0\n";
        let d = parse(text, "x").unwrap();
        assert_eq!(d.format, TrackFormat::Splined);
        let lens: Vec<usize> = d.tracks.iter().map(Track::len).collect();
        assert_eq!(lens, vec![2, 3, 1]);
        assert_eq!(d.tracks[2].id, "2");
        assert!((d.median_step() - 0.02).abs() < 1e-12);
    }

    #[test]
    fn parts_split_the_ids_and_keep_split_pieces_together() {
        let text = "object;time;XSplined;YSplined;ZSplined;VXSplined;VYSplined;VZSplined\n\
            9;0.00;0;0;0;1;0;0\n9;0.02;0.02;0;0;1;0;0\n9;NaN;NaN;NaN;NaN;NaN;NaN;NaN\n\
            9;0.10;0.1;0;0;1;0;0\n4;0.00;5;0;0;0;1;0\n7;0.00;1;0;0;0;1;0\n";
        let d = parse(text, "x").unwrap();
        let ids = |p: &str| -> Vec<String> {
            let part = d.clone().part(p.parse().unwrap());
            part.tracks.iter().map(|t| t.id.clone()).collect()
        };
        // Ids in order of first appearance: 9 (two pieces), 4, 7.
        assert_eq!(ids("0/2"), ["9", "9", "7"]);
        assert_eq!(ids("1/2"), ["4"]);
        assert_eq!(ids("2/3"), ["7"]);
        for bad in ["2/2", "1", "a/2", "0/0", "-1/2"] {
            assert!(bad.parse::<Part>().is_err(), "{bad}");
        }
    }

    #[test]
    fn beeswarm_rows_group_by_id_and_split_at_time_gaps() {
        let mut text = String::from(crate::export::csv::HEADER);
        text.push('\n');
        for f in 0..6 {
            if f == 3 {
                continue; // a dropped frame: 2 × the usual step
            }
            for id in [7, 3] {
                let t = f as f64 * 0.04;
                text += &format!("{id},{f},{t},{t},1,2,1,0,0,0,0,0,1,0,0,0\n");
            }
        }
        let d = parse(&text, "x").unwrap();
        assert_eq!(d.format, TrackFormat::Beeswarm);
        let ids: Vec<&str> = d.tracks.iter().map(|t| t.id.as_str()).collect();
        assert_eq!(ids, vec!["7", "7", "3", "3"]);
        assert_eq!(d.tracks[0].len(), 3);
        assert_eq!(d.tracks[1].len(), 2);
    }

    #[test]
    fn unknown_header_and_bad_numbers_are_reported() {
        assert!(
            parse("a,b,c\n1,2,3\n", "x")
                .unwrap_err()
                .contains("unrecognised header")
        );
        let bad = format!(
            "{}\n1,0,0,x,0,0,0,0,0,0,0,0,1,0,0,0\n",
            crate::export::csv::HEADER
        );
        assert!(parse(&bad, "x").unwrap_err().contains("line 2"));
        assert!(parse("", "x").is_err());
    }
}
