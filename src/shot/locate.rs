//! Maps key paths (`swarm[0].count`) to places in the shot's text, so that every error
//! names the file, line, column and key.

use std::collections::BTreeMap;
use std::ops::Range;
use toml_edit::{ImDocument, Item, Value};

/// Byte spans of a key and of its value.
type Spans = (Option<Range<usize>>, Option<Range<usize>>);

/// The spans of every key and value in a parsed TOML document.
pub struct Locator<'a> {
    src: &'a str,
    /// path → (key span, value span)
    spans: BTreeMap<String, Spans>,
    /// Non-finite floats found anywhere (TOML allows `nan` and `inf`): path and the value
    /// as written (`nan`, `inf` or `-inf`).
    pub non_finite: Vec<(String, &'static str)>,
    /// Lists longer than their fixed length (`center = [0, 1, 0, 99]`): path, expected
    /// length, found length. Deserializing into `[f64; 3]` reads the first three and would
    /// silently ignore the rest.
    pub too_long: Vec<(String, usize, usize)>,
}

/// Keys whose value is a list of fixed length, by their last path segment.
fn fixed_length(path: &str) -> Option<usize> {
    let key = path.rsplit('.').next().unwrap_or(path);
    match key {
        "frames" => Some(2),
        "center" | "size" | "position" | "velocity" | "rotation" | "a" | "b" | "point"
        | "normal" => Some(3),
        _ => None,
    }
}

impl<'a> Locator<'a> {
    pub fn new(src: &'a str) -> Self {
        let mut loc = Locator {
            src,
            spans: BTreeMap::new(),
            non_finite: Vec::new(),
            too_long: Vec::new(),
        };
        if let Ok(doc) = ImDocument::parse(src.to_owned()) {
            loc.walk_table(doc.as_table(), "");
        }
        loc
    }

    fn join(prefix: &str, key: &str) -> String {
        if prefix.is_empty() {
            key.to_owned()
        } else {
            format!("{prefix}.{key}")
        }
    }

    fn walk_table(&mut self, t: &dyn toml_edit::TableLike, prefix: &str) {
        for (k, item) in t.iter() {
            let path = Self::join(prefix, k);
            let key_span = t.key(k).and_then(|key| key.span());
            self.walk_item(item, &path, key_span);
        }
    }

    fn walk_item(&mut self, item: &Item, path: &str, key_span: Option<Range<usize>>) {
        match item {
            Item::Value(v) => self.walk_value(v, path, key_span),
            Item::Table(t) => {
                self.spans.insert(path.to_owned(), (key_span, t.span()));
                self.walk_table(t, path);
            }
            Item::ArrayOfTables(a) => {
                self.spans
                    .insert(path.to_owned(), (key_span.clone(), a.span()));
                for (i, t) in a.iter().enumerate() {
                    let p = format!("{path}[{i}]");
                    self.spans.insert(p.clone(), (t.span(), t.span()));
                    self.walk_table(t, &p);
                }
            }
            Item::None => {}
        }
    }

    fn walk_value(&mut self, v: &Value, path: &str, key_span: Option<Range<usize>>) {
        self.spans.insert(path.to_owned(), (key_span, v.span()));
        match v {
            Value::Float(f) if !f.value().is_finite() => {
                let v = *f.value();
                let text = if v.is_nan() {
                    "nan"
                } else if v > 0.0 {
                    "inf"
                } else {
                    "-inf"
                };
                self.non_finite.push((path.to_owned(), text));
            }
            Value::Array(a) => {
                if let Some(n) = fixed_length(path).filter(|n| a.len() > *n) {
                    self.too_long.push((path.to_owned(), n, a.len()));
                }
                for (i, x) in a.iter().enumerate() {
                    self.walk_value(x, &format!("{path}[{i}]"), x.span());
                }
            }
            Value::InlineTable(t) => self.walk_table(t, path),
            _ => {}
        }
    }

    /// Byte span of a path's value (or of its nearest located parent).
    pub fn span_of(&self, path: &str) -> Option<Range<usize>> {
        let mut p = path.to_owned();
        loop {
            if let Some((k, v)) = self.spans.get(&p) {
                return v.clone().or_else(|| k.clone());
            }
            // Strip the last segment: `a.b[2]` → `a.b` → `a`.
            let cut = p.rfind(['.', '['])?;
            p.truncate(cut);
        }
    }

    /// Byte span of a path's key (for an error about the key itself, such as an unknown
    /// name), else of its value.
    pub fn key_span_of(&self, path: &str) -> Option<Range<usize>> {
        match self.spans.get(path) {
            Some((Some(k), _)) => Some(k.clone()),
            _ => self.span_of(path),
        }
    }

    /// The path whose key or value span is the innermost one containing `pos`.
    pub fn path_at(&self, pos: usize) -> Option<String> {
        self.spans
            .iter()
            .filter_map(|(p, (k, v))| {
                let hit = |r: &Option<Range<usize>>| {
                    r.as_ref()
                        .filter(|r| r.start <= pos && pos < r.end.max(r.start + 1))
                        .map(|r| r.len())
                };
                hit(k).or_else(|| hit(v)).map(|len| (len, p))
            })
            .min_by_key(|(len, _)| *len)
            .map(|(_, p)| p.clone())
    }

    /// 1-based (line, column) of a byte offset, and the text of that line.
    pub fn line_col(&self, pos: usize) -> (usize, usize, String) {
        let pos = pos.min(self.src.len());
        let before = &self.src[..pos];
        let line = before.matches('\n').count() + 1;
        let start = before.rfind('\n').map_or(0, |i| i + 1);
        let col = self.src[start..pos].chars().count() + 1;
        let end = self.src[start..]
            .find('\n')
            .map_or(self.src.len(), |i| start + i);
        // Control characters (binary garbage) would garble the terminal: show them as �.
        let text = self.src[start..end]
            .trim_end_matches('\r')
            .chars()
            .map(|c| {
                if c.is_control() && c != '\t' {
                    '\u{fffd}'
                } else {
                    c
                }
            })
            .collect();
        (line, col, text)
    }
}
