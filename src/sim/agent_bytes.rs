//! Agent state as bytes, for checkpoints: a resumed bake must continue from exactly the
//! state it stopped at, so each model's whole per-agent state is saved, bit for bit.
//!
//! [`AgentBytes`] is declared per agent type, here. Most agents are plain structs of
//! 32-bit floats (positions, velocities, phases), so their bytes *are* their state and
//! [`plain!`] declares them; an agent with other fields (a `bool`) writes them one by one.
//! A new model whose agent is not declared fails to compile where the world builds its
//! swarm, which is the reminder to declare it.

use crate::model::Agent;
use glam::Vec3;

/// An agent type that can be saved and restored exactly: `SIZE` bytes per agent.
pub trait AgentBytes: Agent {
    const SIZE: usize;
    /// Appends this agent's `SIZE` bytes.
    fn write(&self, out: &mut Vec<u8>);
    /// An agent from `SIZE` bytes written by `write`.
    fn read(bytes: &[u8]) -> Self;
}

/// Declares agent types made only of 4-byte fields (`f32`, `glam::Vec3`, tuples and structs
/// of them): no padding, and any bit pattern is a valid value, so the bytes are copied.
macro_rules! plain {
    ($($t:ty),*) => {$(
        const _: () = {
            // A field of another size would bring padding: caught here, at compile time.
            assert!(std::mem::align_of::<$t>() == 4);
            assert!(std::mem::size_of::<$t>().is_multiple_of(4));
        };
        impl AgentBytes for $t {
            const SIZE: usize = std::mem::size_of::<$t>();
            fn write(&self, out: &mut Vec<u8>) {
                // SAFETY: only 4-byte fields (declared above): no padding, every byte
                // of the value is initialised.
                let bytes = unsafe {
                    std::slice::from_raw_parts((self as *const $t).cast::<u8>(), Self::SIZE)
                };
                out.extend_from_slice(bytes);
            }
            fn read(bytes: &[u8]) -> Self {
                assert_eq!(bytes.len(), Self::SIZE);
                // SAFETY: SIZE bytes, and any bit pattern of f32 fields is a valid value;
                // read_unaligned needs no alignment of the source.
                unsafe { std::ptr::read_unaligned(bytes.as_ptr().cast::<$t>()) }
            }
        }
    )*};
}

plain!(
    crate::model::bee::Bee,
    crate::model::flight::Flyer,
    crate::model::butterfly::Butterfly
);

/// Little-endian f32 words, read back in order.
struct Words<'a>(&'a [u8]);

impl Words<'_> {
    fn f32(&mut self) -> f32 {
        let (head, tail) = self.0.split_at(4);
        self.0 = tail;
        f32::from_le_bytes(head.try_into().expect("4 bytes"))
    }
    fn vec3(&mut self) -> Vec3 {
        Vec3::new(self.f32(), self.f32(), self.f32())
    }
}

fn put(out: &mut Vec<u8>, values: &[f32]) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

// Paper 001's insect has a `bool` (minimum distance enforcement moved it): field by field.
impl AgentBytes for crate::model::field::Insect {
    const SIZE: usize = 23 * 4;
    fn write(&self, out: &mut Vec<u8>) {
        put(out, &self.pos.to_array());
        put(out, &self.vel.to_array());
        for a in [&self.attitude, &self.prev] {
            put(out, &a.smooth.to_array());
            put(out, &[a.yaw, a.pitch, a.roll]);
        }
        put(out, &[self.size, self.speed_factor, self.taxis, self.cost]);
        out.extend_from_slice(&u32::from(self.mde).to_le_bytes());
    }
    fn read(bytes: &[u8]) -> Self {
        let mut w = Words(bytes);
        let (pos, vel) = (w.vec3(), w.vec3());
        let mut attitude = || crate::model::field::attitude::Attitude {
            smooth: w.vec3(),
            yaw: w.f32(),
            pitch: w.f32(),
            roll: w.f32(),
        };
        let (attitude, prev) = (attitude(), attitude());
        crate::model::field::Insect {
            pos,
            vel,
            attitude,
            prev,
            size: w.f32(),
            speed_factor: w.f32(),
            taxis: w.f32(),
            cost: w.f32(),
            mde: w.0 != [0; 4],
        }
    }
}

/// Reads a `Flyer` (plain bytes) followed by 32-bit words.
fn flyer_then(bytes: &[u8]) -> (crate::model::flight::Flyer, Words<'_>) {
    let n = <crate::model::flight::Flyer as AgentBytes>::SIZE;
    let (head, tail) = bytes.split_at(n);
    (crate::model::flight::Flyer::read(head), Words(tail))
}

impl Words<'_> {
    fn u32(&mut self) -> u32 {
        self.f32().to_bits()
    }
}

// Paper 003's insect: its flight, its tour of the key points and whether it is startled.
impl AgentBytes for crate::model::fastswarm::Insect {
    const SIZE: usize = <crate::model::flight::Flyer as AgentBytes>::SIZE + 3 * 4;
    fn write(&self, out: &mut Vec<u8>) {
        self.fly.write(out);
        out.extend_from_slice(&self.tour.goal.to_le_bytes());
        out.extend_from_slice(&i32::from(self.tour.way).to_le_bytes());
        out.extend_from_slice(&u32::from(self.startled).to_le_bytes());
    }
    fn read(bytes: &[u8]) -> Self {
        let (fly, mut w) = flyer_then(bytes);
        let goal = w.u32();
        let way = w.u32() as i32 as i8;
        crate::model::fastswarm::Insect {
            fly,
            tour: crate::model::fastswarm::shape::Tour { goal, way },
            startled: w.u32() != 0,
        }
    }
}

// Paper 002's insect: its flight and the escape it is in.
impl AgentBytes for crate::model::zonal::Insect {
    const SIZE: usize = <crate::model::flight::Flyer as AgentBytes>::SIZE + 2 * 4;
    fn write(&self, out: &mut Vec<u8>) {
        self.f.write(out);
        put(out, &[self.escape_theta]);
        out.extend_from_slice(&u32::from(self.escaping).to_le_bytes());
    }
    fn read(bytes: &[u8]) -> Self {
        let (f, mut w) = flyer_then(bytes);
        crate::model::zonal::Insect {
            f,
            escape_theta: w.f32(),
            escaping: w.u32() != 0,
        }
    }
}

/// Appends the bytes of `agents`.
pub fn to_bytes<A: AgentBytes>(agents: &[A], out: &mut Vec<u8>) {
    out.reserve(agents.len() * A::SIZE);
    for a in agents {
        a.write(out);
    }
}

/// Agents from bytes written by [`to_bytes`]; `None` unless `bytes` holds whole agents.
pub fn from_bytes<A: AgentBytes>(bytes: &[u8]) -> Option<Vec<A>> {
    if A::SIZE == 0 || !bytes.len().is_multiple_of(A::SIZE) {
        return None;
    }
    Some(bytes.chunks_exact(A::SIZE).map(A::read).collect())
}
