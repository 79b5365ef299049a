//! Model parameters, declared once per model: name, unit, default, valid range, the phrase
//! an error uses for the range, and a one-line doc. The shot loader validates
//! `params = { … }` against these, `beeswarm models` lists them, and docs/models.md is
//! generated from them.

use super::ModelKind;

/// One tunable of a model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSpec {
    pub name: &'static str,
    /// SI unit as written in the docs ("m", "m/s", "s", "deg", "1" for a plain number).
    pub unit: &'static str,
    pub default: f64,
    /// Valid range, inclusive.
    pub min: f64,
    pub max: f64,
    /// What a valid value is, for error messages: "a weight from 0 to 100".
    pub expected: &'static str,
    pub doc: &'static str,
}

/// A named set of parameter values over a model's defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Preset {
    pub name: &'static str,
    pub doc: &'static str,
    /// (parameter, value) for every parameter that differs from the default.
    pub values: &'static [(&'static str, f64)],
}

/// A model's parameter values, one per [`ParamSpec`] of the model in declaration order.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamValues {
    model: ModelKind,
    values: Vec<f64>,
}

impl ParamValues {
    /// Every parameter at its default.
    pub fn defaults(model: ModelKind) -> Self {
        ParamValues {
            model,
            values: model.info().params.iter().map(|p| p.default).collect(),
        }
    }

    /// A built-in preset of `model` by name.
    pub fn preset(model: ModelKind, name: &str) -> Option<Self> {
        let preset = model.info().presets.iter().find(|p| p.name == name)?;
        let mut v = Self::defaults(model);
        for (k, x) in preset.values {
            let known = v.set(k, *x);
            debug_assert!(known, "preset {name} of {} names `{k}`", model.name());
        }
        Some(v)
    }

    pub fn model(&self) -> ModelKind {
        self.model
    }

    fn index(&self, name: &str) -> Option<usize> {
        self.model.info().params.iter().position(|p| p.name == name)
    }

    /// The value of parameter `name`, or `None` if the model has no such parameter.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.index(name).map(|i| self.values[i])
    }

    /// Sets parameter `name`; false if the model has no such parameter.
    pub fn set(&mut self, name: &str, value: f64) -> bool {
        match self.index(name) {
            Some(i) => {
                self.values[i] = value;
                true
            }
            None => false,
        }
    }

    /// (spec, value) pairs in declaration order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static ParamSpec, f64)> + '_ {
        self.model
            .info()
            .params
            .iter()
            .zip(self.values.iter().copied())
    }

    /// The values in declaration order (what a model's typed view reads).
    pub fn values(&self) -> &[f64] {
        &self.values
    }
}

/// Declares a model's parameters once: the typed struct the model reads (`f64` fields,
/// SI units) and its `SPECS` table, in the same order.
///
/// ```ignore
/// declare_params! {
///     /// Parameters of the X model.
///     pub struct XParams {
///         /// Preferred speed.
///         speed: "m/s", 1.0, [0.01, 50.0], "a speed from 0.01 to 50 m/s";
///     }
/// }
/// ```
#[macro_export]
#[doc(hidden)]
macro_rules! declare_params {
    (
        $(#[$meta:meta])*
        pub struct $name:ident {
            $(
                #[doc = $doc:literal]
                $field:ident : $unit:literal, $default:expr, [$min:expr, $max:expr], $expected:literal;
            )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq)]
        pub struct $name {
            $( #[doc = $doc] pub $field: f64, )*
        }

        impl $name {
            /// Every parameter, in declaration order.
            pub const SPECS: &'static [$crate::model::params::ParamSpec] = &[
                $( $crate::model::params::ParamSpec {
                    name: stringify!($field),
                    unit: $unit,
                    default: $default,
                    min: $min,
                    max: $max,
                    expected: $expected,
                    doc: $doc.trim_ascii(),
                }, )*
            ];

            /// The typed view of validated values of this model.
            pub fn from_values(v: &$crate::model::params::ParamValues) -> Self {
                let mut it = v.values().iter().copied();
                let out = $name { $( $field: it.next().expect(stringify!($field)), )* };
                debug_assert!(it.next().is_none(), "values of another model");
                out
            }
        }

        impl Default for $name {
            fn default() -> Self {
                $name { $( $field: $default, )* }
            }
        }
    };
}

/// The preset list of a model whose only preset is its defaults.
pub const DEFAULTS_ONLY: &[Preset] = &[Preset {
    name: "default",
    doc: "the defaults",
    values: &[],
}];
