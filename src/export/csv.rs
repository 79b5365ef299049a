//! Tracks CSV: one row per bee per frame, for analysis (`beeswarm eval`) and tests.
//!
//! Columns: `id,frame,time,x,y,z,vx,vy,vz,qx,qy,qz,qw,pitch,roll,sway`. Metres, seconds,
//! metres per second; Y-up right-handed; quaternion (x, y, z, w) body → world; pitch and
//! roll in degrees; sway in metres. Floats use the shortest text that reads back exactly.

use super::CacheWriter;
use crate::atomic::{AtomicFile, SealedFile};
use crate::error::{Error, Result};
use crate::sim::{CacheMeta, Frame};
use std::io::Write;
use std::path::Path;

pub const HEADER: &str = "id,frame,time,x,y,z,vx,vy,vz,qx,qy,qz,qw,pitch,roll,sway";

pub struct CsvWriter {
    file: AtomicFile,
    line: Vec<u8>,
}

impl CsvWriter {
    pub fn create(path: &Path, _meta: &CacheMeta) -> Result<Self> {
        let mut file = AtomicFile::create(path)?;
        writeln!(file, "{HEADER}").map_err(|e| Error::io(path, e))?;
        Ok(CsvWriter {
            file,
            line: Vec::with_capacity(256),
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
        for s in frame.swarms {
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
                for x in [
                    p.x,
                    p.y,
                    p.z,
                    v.x,
                    v.y,
                    v.z,
                    q.x,
                    q.y,
                    q.z,
                    q.w,
                    s.pitch_deg[i],
                    s.roll_deg[i],
                    s.sway_m[i],
                ] {
                    l.push(b',');
                    push_f32(l, x);
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
