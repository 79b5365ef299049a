//! `--vary KEY=VALUES` and `--variant KEY=VALUE;KEY=VALUE`: which keys of a shot a wedge
//! changes, and the list of variants they make.
//!
//! Keys are the shot's own TOML keys, dotted: `scene.seed` (or just `seed`: a bare key is
//! a `[scene]` key), `swarm.bees.params.speed` (an array of tables — `swarm`, `obstacle`,
//! `target` — is addressed by the element's `name`, or by its 0-based index), `wind.velocity`.
//! Values are TOML values (`1.2`, `"nest"`, `[0, 1, 0]`; a bare word is a string), separated
//! by commas outside brackets and quotes; `A..B` is every whole number from A to B.

use crate::error::{Error, Result};

/// The most variants one wedge makes: each is a bake and a task on the farm.
pub const MAX_VARIANTS: usize = 10_000;

/// One key and the values a wedge gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct Vary {
    pub key: String,
    /// TOML value text, one per value.
    pub values: Vec<String>,
}

/// One variant: the keys it sets, in the order given.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    pub assignments: Vec<(String, String)>,
}

impl Variant {
    /// `seed=3 speed=1.2`: the last segment of each key, for labels on the contact sheet.
    pub fn label(&self) -> String {
        self.assignments
            .iter()
            .map(|(k, v)| format!("{}={}", k.rsplit('.').next().unwrap_or(k), v))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// Parses `KEY=VALUES` (the `--vary` option).
pub fn parse_vary(s: &str) -> std::result::Result<Vary, String> {
    let (key, values) = s.split_once('=').ok_or_else(|| {
        format!(
            "expected KEY=VALUES, e.g. seed=1..8 or swarm.bees.params.speed=0.8,1.2, found \"{s}\""
        )
    })?;
    let key = parse_key(key)?;
    let mut out = Vec::new();
    for v in split_values(values, ',')? {
        match parse_range(&v)? {
            Some((a, b)) => out.extend((a..=b).map(|i| i.to_string())),
            None => out.push(v),
        }
        if out.len() > MAX_VARIANTS {
            return Err(format!("{key}: more than {MAX_VARIANTS} values"));
        }
    }
    if out.is_empty() {
        return Err(format!("{key}: expected at least one value after '='"));
    }
    Ok(Vary { key, values: out })
}

/// Parses `KEY=VALUE;KEY=VALUE` (the `--variant` option): one explicit variant.
pub fn parse_variant(s: &str) -> std::result::Result<Variant, String> {
    let mut assignments = Vec::new();
    for part in split_values(s, ';')? {
        let (key, value) = part
            .split_once('=')
            .ok_or_else(|| format!("expected KEY=VALUE;KEY=VALUE, found \"{part}\""))?;
        let value = value.trim();
        if value.is_empty() {
            return Err(format!("{}: expected a value after '='", key.trim()));
        }
        assignments.push((parse_key(key)?, value.to_owned()));
    }
    if assignments.is_empty() {
        return Err("expected KEY=VALUE;KEY=VALUE, found nothing".to_owned());
    }
    Ok(Variant { assignments })
}

fn parse_key(key: &str) -> std::result::Result<String, String> {
    let key = key.trim();
    let ok = !key.is_empty()
        && key.split('.').all(|seg| {
            !seg.is_empty()
                && seg
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        });
    if !ok {
        return Err(format!(
            "expected a dotted shot key such as seed or swarm.bees.params.speed, found \"{key}\""
        ));
    }
    Ok(key.to_owned())
}

/// `A..B` with whole numbers, A ≤ B; `None` if `v` is not a range.
fn parse_range(v: &str) -> std::result::Result<Option<(i64, i64)>, String> {
    let Some((a, b)) = v.split_once("..") else {
        return Ok(None);
    };
    let (Ok(a), Ok(b)) = (a.trim().parse::<i64>(), b.trim().parse::<i64>()) else {
        return Err(format!(
            "expected a range of whole numbers such as 1..8, found \"{v}\""
        ));
    };
    if a > b {
        return Err(format!("the range {a}..{b} is reversed; write {b}..{a}"));
    }
    if (b as i128 - a as i128) >= MAX_VARIANTS as i128 {
        return Err(format!(
            "the range {a}..{b} makes more than {MAX_VARIANTS} values"
        ));
    }
    Ok(Some((a, b)))
}

/// Splits at `sep` outside brackets, braces and quotes; trims each part.
fn split_values(s: &str, sep: char) -> std::result::Result<Vec<String>, String> {
    let mut parts = Vec::new();
    let (mut depth, mut quote, mut cur) = (0i32, None::<char>, String::new());
    for c in s.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), _) => {}
            (None, '"' | '\'') => quote = Some(c),
            (None, '[' | '{') => depth += 1,
            (None, ']' | '}') => depth -= 1,
            (None, c) if c == sep && depth == 0 => {
                parts.push(std::mem::take(&mut cur).trim().to_owned());
                continue;
            }
            _ => {}
        }
        cur.push(c);
    }
    if quote.is_some() || depth != 0 {
        return Err(format!("unbalanced quotes or brackets in \"{s}\""));
    }
    parts.push(cur.trim().to_owned());
    if parts.iter().any(String::is_empty) {
        return Err(format!("an empty value in \"{s}\""));
    }
    Ok(parts)
}

/// The variants of a wedge: the explicit `--variant`s, else every combination of the
/// `--vary` values (the first key varying slowest).
pub fn expand(varies: &[Vary], explicit: &[Variant]) -> Result<Vec<Variant>> {
    if !explicit.is_empty() {
        if !varies.is_empty() {
            return Err(Error::input(
                "give either --vary (every combination) or --variant (an explicit list), not both",
            ));
        }
        return Ok(explicit.to_vec());
    }
    if varies.is_empty() {
        return Err(Error::input(
            "a wedge needs at least one --vary KEY=VALUES or --variant KEY=VALUE",
        ));
    }
    for (i, v) in varies.iter().enumerate() {
        if varies[..i].iter().any(|w| w.key == v.key) {
            return Err(Error::input(format!(
                "--vary {} is given twice; list all its values in one --vary",
                v.key
            )));
        }
    }
    let total = varies
        .iter()
        .try_fold(1usize, |n, v| n.checked_mul(v.values.len()))
        .filter(|&n| n <= MAX_VARIANTS)
        .ok_or_else(|| {
            Error::input(format!(
                "the --vary values make more than {MAX_VARIANTS} variants"
            ))
        })?;
    let mut out = Vec::with_capacity(total);
    for mut k in 0..total {
        let mut assignments = vec![(String::new(), String::new()); varies.len()];
        for (i, v) in varies.iter().enumerate().rev() {
            let n = v.values.len();
            assignments[i] = (v.key.clone(), v.values[k % n].clone());
            k /= n;
        }
        out.push(Variant { assignments });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_lists_and_arrays() {
        let v = parse_vary("seed=1..3").unwrap();
        assert_eq!(v.values, ["1", "2", "3"]);
        let v = parse_vary("wind.velocity=[1, 0, 0],[0,0,1]").unwrap();
        assert_eq!(v.values, ["[1, 0, 0]", "[0,0,1]"]);
        let v = parse_vary("swarm.bees.preset=nest, \"a,b.toml\"").unwrap();
        assert_eq!(v.values, ["nest", "\"a,b.toml\""]);
        assert!(parse_vary("seed=3..1").unwrap_err().contains("reversed"));
        assert!(parse_vary("seed").is_err());
        assert!(parse_vary("se ed=1").is_err());
        assert!(parse_vary("seed=1,,2").is_err());
        assert!(parse_vary("seed=[1").is_err());
    }

    #[test]
    fn product_first_key_slowest() {
        let a = parse_vary("seed=1..2").unwrap();
        let b = parse_vary("swarm.bees.params.speed=0.8,1.2").unwrap();
        let all = expand(&[a, b], &[]).unwrap();
        let labels: Vec<_> = all.iter().map(Variant::label).collect();
        assert_eq!(
            labels,
            [
                "seed=1 speed=0.8",
                "seed=1 speed=1.2",
                "seed=2 speed=0.8",
                "seed=2 speed=1.2"
            ]
        );
        let explicit = parse_variant("seed=4; swarm.bees.count=10").unwrap();
        assert_eq!(explicit.label(), "seed=4 count=10");
        assert!(expand(&[], &[]).is_err());
    }
}
