//! What a bake writes: the cache formats and their per-format settings (`[output]`).

/// A cache format the bake can write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Format {
    Glb,
    Gltf,
    Usda,
    Csv,
}

impl Format {
    pub const ALL: [Format; 4] = [Format::Glb, Format::Gltf, Format::Usda, Format::Csv];

    pub fn name(self) -> &'static str {
        match self {
            Format::Glb => "glb",
            Format::Gltf => "gltf",
            Format::Usda => "usda",
            Format::Csv => "csv",
        }
    }

    pub fn parse(s: &str) -> Option<Format> {
        Format::ALL
            .into_iter()
            .find(|f| f.name() == s.trim().to_ascii_lowercase())
    }

    /// The file a format writes for a shot (gltf also writes `<name>.bin` beside it).
    pub fn file_name(self, shot_name: &str) -> String {
        match self {
            Format::Csv => format!("{shot_name}.tracks.csv"),
            f => format!("{shot_name}.{}", f.name()),
        }
    }
}

/// How wings are drawn in the caches (glTF and USD alike). A real wing beat (a honeybee's
/// 230 Hz) sampled at 24–60 fps aliases into noise, so the caches show a stand-in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WingDisplay {
    /// Held at mid-stroke, a clear membrane: a fast shutter's view.
    Still,
    /// A translucent fan of ghosted wings over the whole stroke: a slow shutter's view of
    /// the real beat.
    Blur,
    /// A stylised flap at a visible rate (Hz, above 0 and at most fps / 2), in phase
    /// groups so a swarm does not beat in lockstep.
    Flap { hz: f64 },
}

impl WingDisplay {
    pub fn name(self) -> &'static str {
        match self {
            WingDisplay::Still => "still",
            WingDisplay::Blur => "blur",
            WingDisplay::Flap { .. } => "flap",
        }
    }

    /// The flap rate in Hz; 0 when the wings do not move.
    pub fn flap_hz(self) -> f64 {
        match self {
            WingDisplay::Flap { hz } => hz,
            _ => 0.0,
        }
    }
}

/// The glTF scene layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GltfLayout {
    /// One node per agent (its path), one per part under it (body motion, wings): the
    /// most to animate with, 2–4 animated nodes per agent.
    Parts,
    /// One animated node per agent holding the simulated pose and the static parts as one
    /// mesh; only parts that move on their own (a flapping wing) get child nodes. Far
    /// faster to import (one object and two tracks per agent).
    Agent,
}

impl GltfLayout {
    pub fn name(self) -> &'static str {
        match self {
            GltfLayout::Parts => "parts",
            GltfLayout::Agent => "agent",
        }
    }
}

/// Per-format settings from the shot's `[output]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputOptions {
    /// How wings are drawn, in every format that draws them.
    pub wings: WingDisplay,
    /// The glTF scene layout.
    pub gltf_layout: GltfLayout,
    /// Split USDA time samples into value clips of this many frames (0 = one file);
    /// `None`: chosen from the cache's size (see `export::usda::auto_clip_frames`).
    pub usda_clip_frames: Option<u32>,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            wings: WingDisplay::Blur,
            gltf_layout: GltfLayout::Parts,
            usda_clip_frames: None,
        }
    }
}
