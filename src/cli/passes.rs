//! `--passes`: which layers the EXR holds beside the beauty.

/// The passes asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassChoice {
    /// The light passes (`film::passes::LIGHT_PASSES`).
    pub light: bool,
    /// The data passes (`film::passes::DATA_PASSES`).
    pub data: bool,
    /// The light groups (`render::light_groups`).
    pub lights: bool,
}

/// Parses a comma-separated list of `beauty`, `light`, `data`, `lights` and `all` (every
/// one).
pub fn parse(s: &str) -> Result<PassChoice, String> {
    let mut choice = PassChoice::default();
    for word in s.split(',').map(str::trim) {
        match word {
            "beauty" => {}
            "light" => choice.light = true,
            "data" => choice.data = true,
            "lights" => choice.lights = true,
            "all" => {
                choice.light = true;
                choice.data = true;
                choice.lights = true;
            }
            other => {
                return Err(format!(
                    "'{other}' is not a pass list entry; expected beauty, light, data, lights \
                     or all, separated by commas"
                ))
            }
        }
    }
    Ok(choice)
}
