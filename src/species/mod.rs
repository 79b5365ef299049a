//! How agents are drawn and what they record (interim: replaced by the species branch).

/// A per-agent scalar a model records each frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Channel {
    pub name: &'static str,
    pub unit: &'static str,
    pub doc: &'static str,
}

#[derive(Debug)]
pub struct Species {
    pub name: &'static str,
}

pub static HONEYBEE: Species = Species { name: "honeybee" };

pub const BEE_CHANNELS: [Channel; 3] = [
    Channel {
        name: "pitch",
        unit: "deg",
        doc: "Body pitch, degrees, nose up positive (about body +Z).",
    },
    Channel {
        name: "roll",
        unit: "deg",
        doc: "Body roll, degrees, right wing down positive (about body +X).",
    },
    Channel {
        name: "sway",
        unit: "m",
        doc: "Lateral offset from the mean path, metres, along the heading's +Z.",
    },
];
