//! Render metadata stored in image headers, so an output file says how it was made.
use std::fmt;

/// One header attribute value. Written to OpenEXR as `string`, `float`, `double` or `int`.
#[derive(Debug, Clone, PartialEq)]
pub enum AttrValue {
    /// UTF-8 text (OpenEXR strings are byte strings; OpenImageIO reads them as UTF-8).
    Text(String),
    /// 32-bit float.
    Float(f32),
    /// 64-bit float, for values such as seconds that need more than 7 digits.
    Double(f64),
    /// 32-bit signed integer.
    Int(i32),
}

impl fmt::Display for AttrValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AttrValue::Text(s) => write!(f, "{s}"),
            AttrValue::Float(v) => write!(f, "{v}"),
            AttrValue::Double(v) => write!(f, "{v}"),
            AttrValue::Int(v) => write!(f, "{v}"),
        }
    }
}

/// Header attributes in the order they were set. Names are unique: setting an existing name
/// replaces its value in place.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Metadata {
    entries: Vec<(String, AttrValue)>,
}

impl Metadata {
    /// No attributes.
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets `name` to `value`, replacing an earlier value of the same name.
    pub fn set(&mut self, name: impl Into<String>, value: AttrValue) -> &mut Self {
        let name = name.into();
        match self.entries.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => *v = value,
            None => self.entries.push((name, value)),
        }
        self
    }

    /// Builder form of [`Metadata::set`].
    pub fn with(mut self, name: impl Into<String>, value: AttrValue) -> Self {
        self.set(name, value);
        self
    }

    /// The value of `name`, if set.
    pub fn get(&self, name: &str) -> Option<&AttrValue> {
        self.entries.iter().find(|(n, _)| n == name).map(|(_, v)| v)
    }

    /// The value of `name` if it is text.
    pub fn text(&self, name: &str) -> Option<&str> {
        match self.get(name) {
            Some(AttrValue::Text(s)) => Some(s),
            _ => None,
        }
    }

    /// The attributes in insertion order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &AttrValue)> {
        self.entries.iter().map(|(n, v)| (n.as_str(), v))
    }

    /// Number of attributes.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there are no attributes.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// The same attributes sorted by name, for comparing sets of attributes read back from a
    /// file (OpenEXR does not keep their order).
    pub fn sorted(&self) -> Metadata {
        let mut entries = self.entries.clone();
        entries.sort_by(|a, b| a.0.cmp(&b.0));
        Metadata { entries }
    }
}

/// Prefix of every attribute Brume writes, so they stand apart from standard EXR attributes.
pub const PREFIX: &str = "brume:";

/// How a render was made: the fields every Brume output records.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RenderInfo {
    /// Transmittance / free-flight estimator, e.g. "ratio" or "residual_ratio".
    pub estimator: String,
    /// The estimator's `b` parameter (its meaning is the estimator's; 0 where unused).
    pub b: f32,
    /// The estimator's `m` parameter (its meaning is the estimator's; 0 where unused).
    pub m: f32,
    /// How majorants were chosen, e.g. "dda" or "global".
    pub majorant_mode: String,
    /// Samples per pixel.
    pub spp: u32,
    /// Render wall time in seconds.
    pub seconds: f64,
    /// Seed of the random streams.
    pub seed: u64,
    /// The scene file rendered.
    pub scene: String,
    /// Backend and adapter, e.g. "cpu (16 threads)" or "wgpu: llvmpipe (Vulkan)".
    pub backend: String,
}

impl RenderInfo {
    /// The header attributes, named `brume:FIELD`, plus `brume:version`. The seed is text
    /// because no EXR number type holds every u64 exactly; spp is an int where it fits.
    pub fn to_metadata(&self) -> Metadata {
        let key = |field: &str| format!("{PREFIX}{field}");
        let spp = match i32::try_from(self.spp) {
            Ok(v) => AttrValue::Int(v),
            Err(_) => AttrValue::Double(self.spp as f64),
        };
        Metadata::new()
            .with(key("estimator"), AttrValue::Text(self.estimator.clone()))
            .with(key("b"), AttrValue::Float(self.b))
            .with(key("m"), AttrValue::Float(self.m))
            .with(
                key("majorant_mode"),
                AttrValue::Text(self.majorant_mode.clone()),
            )
            .with(key("spp"), spp)
            .with(key("seconds"), AttrValue::Double(self.seconds))
            .with(key("seed"), AttrValue::Text(self.seed.to_string()))
            .with(key("scene"), AttrValue::Text(self.scene.clone()))
            .with(
                key("version"),
                AttrValue::Text(env!("CARGO_PKG_VERSION").into()),
            )
            .with(key("backend"), AttrValue::Text(self.backend.clone()))
    }
}
