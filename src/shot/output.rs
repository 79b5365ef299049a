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

/// Per-format settings from the shot's `[output]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct OutputOptions {
    /// Visible wing flap rate written to glTF wing tracks, Hz. 0 = a static blurred pose.
    pub gltf_wing_flap_hz: f64,
    /// Split USDA time samples into value clips of this many frames (0 = one file);
    /// `None`: chosen from the cache's size (see `export::usda::auto_clip_frames`).
    pub usda_clip_frames: Option<u32>,
}

impl Default for OutputOptions {
    fn default() -> Self {
        OutputOptions {
            gltf_wing_flap_hz: 0.0,
            usda_clip_frames: None,
        }
    }
}
