//! Tracks CSV: one row per agent per frame, for analysis (`beeswarm eval`) and tests.
//!
//! Columns: `id,frame,time,x,y,z,vx,vy,vz,qx,qy,qz,qw`, then one column per channel the
//! shot's models record (`SwarmMeta::channels`): the union over the swarms, in order of
//! first appearance; a swarm that does not record a channel leaves its cells empty. A
//! honeybee shot: `…,qw,pitch,roll,sway,state` ([`HEADER`]). Metres, seconds, metres per
//! second; Y-up right-handed; quaternion (x, y, z, w) body → world; channels in their own
//! units (honeybee: pitch and roll in degrees, sway in metres). Floats use the shortest
//! text that reads back exactly.

use super::CacheWriter;
use crate::atomic::{AtomicFile, SealedFile};
use crate::error::{Error, Result};
use crate::sim::{CacheMeta, Frame};
use std::io::Write;
use std::path::Path;

/// The columns every tracks CSV starts with.
pub const BASE_HEADER: &str = "id,frame,time,x,y,z,vx,vy,vz,qx,qy,qz,qw";

/// The header of a shot whose swarms all record the honeybee channels
/// (`species::BEE_CHANNELS`).
pub const HEADER: &str = "id,frame,time,x,y,z,vx,vy,vz,qx,qy,qz,qw,pitch,roll,sway,state";

/// The channel columns of a shot: every channel name of every swarm, in order of first
/// appearance.
pub fn channel_columns(meta: &CacheMeta) -> Vec<&'static str> {
    let mut names: Vec<&'static str> = Vec::new();
    for c in meta.swarms.iter().flat_map(|s| &s.channels) {
        if !names.contains(&c.name) {
            names.push(c.name);
        }
    }
    names
}

/// The header line of a shot's tracks CSV (without the newline).
pub fn header(meta: &CacheMeta) -> String {
    let mut h = String::from(BASE_HEADER);
    for name in channel_columns(meta) {
        h.push(',');
        h.push_str(name);
    }
    h
}

pub struct CsvWriter {
    file: AtomicFile,
    line: Vec<u8>,
    /// Per swarm, per channel column of the file: the swarm's channel index, if any.
    columns: Vec<Vec<Option<usize>>>,
}

impl CsvWriter {
    pub fn create(path: &Path, meta: &CacheMeta) -> Result<Self> {
        let names = channel_columns(meta);
        let columns = meta
            .swarms
            .iter()
            .map(|s| names.iter().map(|n| s.channel(n)).collect())
            .collect();
        let mut file = AtomicFile::create(path)?;
        writeln!(file, "{}", header(meta)).map_err(|e| Error::io(path, e))?;
        Ok(CsvWriter {
            file,
            line: Vec::with_capacity(256),
            columns,
        })
    }
}

/// Appends a float in shortest round-trip form (never NaN or inf: the simulation guards them).
pub fn push_f32(out: &mut Vec<u8>, v: f32) {
    debug_assert!(v.is_finite());
    let v = if v == 0.0 { 0.0 } else { v }; // no "-0"
    let mut b = ryu::Buffer::new();
    let s = b.format_finite(v);
    out.extend_from_slice(s.strip_suffix(".0").unwrap_or(s).as_bytes());
}

impl CacheWriter for CsvWriter {
    fn write_frame(&mut self, frame: &Frame) -> Result<()> {
        let mut itoa_buf = itoa::Buffer::new();
        let time = ryu::Buffer::new().format_finite(frame.time).to_owned();
        if frame.swarms.len() != self.columns.len() {
            return Err(Error::bake(format!(
                "CSV writer: frame {} has {} swarms, the shot has {}",
                frame.frame,
                frame.swarms.len(),
                self.columns.len()
            )));
        }
        for (s, columns) in frame.swarms.iter().zip(&self.columns) {
            for i in 0..s.len() {
                let l = &mut self.line;
                l.clear();
                l.extend_from_slice(itoa_buf.format(s.ids[i]).as_bytes());
                l.push(b',');
                l.extend_from_slice(itoa_buf.format(frame.frame).as_bytes());
                l.push(b',');
                l.extend_from_slice(time.strip_suffix(".0").unwrap_or(&time).as_bytes());
                let p = s.position[i];
                let v = s.velocity[i];
                let q = s.orientation[i];
                for x in [p.x, p.y, p.z, v.x, v.y, v.z, q.x, q.y, q.z, q.w] {
                    l.push(b',');
                    push_f32(l, x);
                }
                for column in columns {
                    l.push(b',');
                    if let Some(c) = *column {
                        push_f32(l, s.channels[c][i]);
                    }
                }
                l.push(b'\n');
                if let Err(e) = self.file.writer().write_all(&self.line) {
                    return Err(Error::io(self.file.dest(), e));
                }
            }
        }
        Ok(())
    }

    fn finish(self: Box<Self>) -> Result<Vec<SealedFile>> {
        Ok(vec![self.file.seal()?])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{SwarmFrame, SwarmMeta};
    use crate::species::{BEE_CHANNELS, Channel, HONEYBEE};
    use glam::{Quat, Vec3};

    fn swarm(name: &str, count: usize, channels: Vec<Channel>) -> SwarmMeta {
        SwarmMeta {
            name: name.into(),
            count,
            species: &HONEYBEE,
            channels,
            body_length_m: 0.012,
            wing_beat_hz: 230.0,
            hidden: None,
        }
    }

    fn frame_of(m: &SwarmMeta, first_id: u64) -> SwarmFrame {
        let n = m.count;
        SwarmFrame {
            ids: (0..n as u64).map(|i| first_id + i).collect(),
            position: vec![Vec3::new(1.0, 2.0, -0.5); n],
            velocity: vec![Vec3::X; n],
            orientation: vec![Quat::IDENTITY; n],
            heading: vec![Quat::IDENTITY; n],
            angular_velocity_deg: vec![Vec3::ZERO; n],
            scale: vec![1.0; n],
            channels: (0..m.channels.len())
                .map(|c| (0..n).map(|i| (10 * c + i) as f32 + 0.5).collect())
                .collect(),
        }
    }

    fn bake(meta: &CacheMeta) -> String {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.tracks.csv");
        let mut w: Box<dyn CacheWriter> = Box::new(CsvWriter::create(&path, meta).unwrap());
        let mut first_id = 0;
        let swarms: Vec<SwarmFrame> = meta
            .swarms
            .iter()
            .map(|s| {
                first_id += 100;
                frame_of(s, first_id)
            })
            .collect();
        w.write_frame(&Frame {
            frame: 1,
            time: 0.0,
            swarms: &swarms,
        })
        .unwrap();
        crate::atomic::commit_all(w.finish().unwrap()).unwrap();
        std::fs::read_to_string(path).unwrap()
    }

    fn meta(swarms: Vec<SwarmMeta>) -> CacheMeta {
        CacheMeta {
            shot_name: "t".into(),
            fps: 24.0,
            frame_start: 1,
            frame_end: 1,
            seed: 1,
            tool_version: "0".into(),
            swarms,
        }
    }

    #[test]
    fn a_honeybee_shot_has_the_bee_header() {
        let m = meta(vec![swarm("a", 1, BEE_CHANNELS.to_vec())]);
        assert_eq!(header(&m), HEADER);
        let text = bake(&m);
        assert_eq!(
            text,
            format!("{HEADER}\n100,1,0,1,2,-0.5,1,0,0,0,0,0,1,0.5,10.5,20.5,30.5\n")
        );
    }

    #[test]
    fn swarms_with_other_channels_leave_empty_cells() {
        let stroke = Channel {
            name: "stroke",
            unit: "deg",
            doc: "Wing stroke.",
        };
        let m = meta(vec![
            swarm("bees", 2, BEE_CHANNELS.to_vec()),
            swarm("flies", 1, vec![stroke, BEE_CHANNELS[1]]),
        ]);
        let text = bake(&m);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[0], format!("{HEADER},stroke"));
        assert_eq!(
            lines[1..],
            [
                "100,1,0,1,2,-0.5,1,0,0,0,0,0,1,0.5,10.5,20.5,30.5,",
                "101,1,0,1,2,-0.5,1,0,0,0,0,0,1,1.5,11.5,21.5,31.5,",
                // roll is the flies' second channel, stroke their first
                "200,1,0,1,2,-0.5,1,0,0,0,0,0,1,,10.5,,,0.5",
            ]
        );
        // tests/eval.rs reads such a file back with `beeswarm eval`'s reader.
    }
}
