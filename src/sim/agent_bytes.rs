//! Agent state as bytes, for checkpoints: a resumed bake must continue from exactly the
//! state it stopped at, so each model's whole per-agent state is saved, bit for bit.
//!
//! Agent types are plain structs of 32-bit floats (positions, velocities, phases), so
//! their bytes *are* their state; [`PlainAgent`] declares that, per type, here. A new
//! model whose agent is not declared fails to compile where the world builds its swarm,
//! which is the reminder to declare it (or to give it explicit (de)serialisation).

use crate::model::Agent;

/// An agent type whose every byte is state: only 4-byte fields (`f32`, `u32`, `glam::Vec3`
/// and tuples or structs of them), so no padding, and any bit pattern is a valid value.
///
/// # Safety
/// Implement only for such types: [`to_bytes`] reads every byte of the value and
/// [`from_bytes`] makes values from arbitrary bytes.
pub unsafe trait PlainAgent: Agent {}

// SAFETY: every field is an f32 or a struct of f32s (`Cruiser`, `Vec3`, `(f32, f32, f32)`).
unsafe impl PlainAgent for crate::model::bee::Bee {}
// SAFETY: `Cruiser` (f32s and Vec3s) and an f32.
unsafe impl PlainAgent for crate::model::flight::Flyer {}

// A field of another size would bring padding (or a type with invalid bit patterns):
// these do not prove its absence, but catch the likely mistakes at compile time.
const _: () = {
    use crate::model::{bee::Bee, flight::Flyer};
    use std::mem::{align_of, size_of};
    assert!(align_of::<Bee>() == 4 && size_of::<Bee>().is_multiple_of(4));
    assert!(align_of::<Flyer>() == 4 && size_of::<Flyer>().is_multiple_of(4));
};

/// Appends the bytes of `agents` (native byte order).
pub fn to_bytes<A: PlainAgent>(agents: &[A], out: &mut Vec<u8>) {
    // SAFETY: `PlainAgent` types have no padding, so every byte of the slice is initialised.
    let bytes = unsafe {
        std::slice::from_raw_parts(agents.as_ptr().cast::<u8>(), std::mem::size_of_val(agents))
    };
    out.extend_from_slice(bytes);
}

/// Agents from bytes written by [`to_bytes`]; `None` unless `bytes` holds whole agents.
pub fn from_bytes<A: PlainAgent>(bytes: &[u8]) -> Option<Vec<A>> {
    let size = std::mem::size_of::<A>();
    if size == 0 || !bytes.len().is_multiple_of(size) {
        return None;
    }
    let n = bytes.len() / size;
    let mut out: Vec<A> = Vec::with_capacity(n);
    // SAFETY: the vector has room for n agents; any bit pattern is a valid `PlainAgent`;
    // the copy is bytewise, so the source needs no alignment.
    unsafe {
        std::ptr::copy_nonoverlapping(bytes.as_ptr(), out.as_mut_ptr().cast::<u8>(), n * size);
        out.set_len(n);
    }
    Some(out)
}
