//! `--passes`: which layers the EXR holds beside the beauty.

/// The passes asked for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassChoice {
    /// The light passes (`film::passes::LIGHT_PASSES`).
    pub light: bool,
}

/// Parses a comma-separated list of `beauty` and `light`.
pub fn parse(s: &str) -> Result<PassChoice, String> {
    let mut choice = PassChoice::default();
    for word in s.split(',').map(str::trim) {
        match word {
            "beauty" => {}
            "light" => choice.light = true,
            "data" | "lights" | "all" => {
                return Err(format!(
                    "'{word}': the data passes and per-light groups are not available; the \
                     passes are beauty and light"
                ))
            }
            other => {
                return Err(format!(
                    "'{other}' is not a pass list entry; expected beauty or light, separated by \
                     commas"
                ))
            }
        }
    }
    Ok(choice)
}
