//! Light groups (`--passes lights`): the beauty split by the light it comes from, one layer per
//! glTF punctual light, the environment, the emissive surfaces together and each emitting VDB
//! medium, as Cycles' light groups and Arnold's per-light AOVs. Every contribution a path
//! gathers has exactly one source, so the groups add up to the beauty.
use super::lights::LightSource;
use crate::scene::Scene;

/// Most groups a render keeps: each costs three running means per pixel and a slot in every
/// path's state.
pub const MAX_LIGHT_GROUPS: usize = 16;

/// A source that is in no group (a medium that does not emit).
pub const NO_GROUP: u8 = u8::MAX;

/// The groups of a scene and which group each source gathers into.
#[derive(Clone, Debug, PartialEq)]
pub struct LightGroups {
    /// Layer names, in group order: `light.<name>`, `environment`, `surfaces`,
    /// `medium.<name>`.
    pub names: Vec<String>,
    /// The group of each punctual light (`Scene::lights` order).
    pub punctual: Vec<u8>,
    /// The environment's group ([`NO_GROUP`] where it is black).
    pub environment: u8,
    /// The emissive surfaces' group ([`NO_GROUP`] without any).
    pub surfaces: u8,
    /// The group of each rendered VDB medium (`RenderScene::vdb` order), [`NO_GROUP`] where
    /// it does not emit.
    pub media: Vec<u8>,
}

impl LightGroups {
    /// The groups of `scene` (none where nothing emits); an error naming the file where it has
    /// more than [`MAX_LIGHT_GROUPS`] sources of light.
    pub fn of(scene: &Scene) -> Result<LightGroups, String> {
        let mut names = Names::default();
        let punctual = (0..scene.lights.len())
            .map(|k| {
                let name = scene.light_names[k].as_deref();
                names.add("light", name.unwrap_or(&format!("{k}")))
            })
            .collect();
        let environment = if scene.environment.radiance.iter().any(|&c| c > 0.0) {
            names.add_plain("environment")
        } else {
            NO_GROUP
        };
        let surfaces = if scene.materials.iter().any(|m| m.emission != [0.0; 3]) {
            names.add_plain("surfaces")
        } else {
            NO_GROUP
        };
        let media = scene
            .vdb_media
            .iter()
            .enumerate()
            .filter(|(_, d)| d.rendered())
            .map(|(k, d)| match d.emits() {
                true => names.add("medium", d.name.as_deref().unwrap_or(&format!("{k}"))),
                false => NO_GROUP,
            })
            .collect();
        let file = scene.source.display();
        if names.list.len() > MAX_LIGHT_GROUPS {
            return Err(format!(
                "{file}: --passes lights: the scene has {} sources of light ({}); a render keeps \
                 at most {MAX_LIGHT_GROUPS} light groups",
                names.list.len(),
                names.list.join(", ")
            ));
        }
        Ok(LightGroups {
            names: names.list,
            punctual,
            environment,
            surfaces,
            media,
        })
    }

    /// The group a light sample's source gathers into.
    pub fn of_source(&self, source: LightSource) -> u8 {
        match source {
            LightSource::Punctual(k) => self.punctual[k as usize],
            LightSource::Environment => self.environment,
            LightSource::Area => self.surfaces,
            LightSource::Medium(k) => self.media[k as usize],
        }
    }

    /// The number of groups.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}

/// Layer names, unique and safe as EXR layer names.
#[derive(Default)]
struct Names {
    list: Vec<String>,
}

impl Names {
    /// `<kind>.<name>`, `name` reduced to letters, digits, `_` and `-` (a dot would split the
    /// layer in Nuke and Blender), with a suffix where it repeats.
    fn add(&mut self, kind: &str, name: &str) -> u8 {
        let clean: String = name
            .chars()
            .map(|c| match c.is_alphanumeric() || c == '-' {
                true => c,
                false => '_',
            })
            .collect();
        self.add_plain(&format!("{kind}.{clean}"))
    }

    fn add_plain(&mut self, base: &str) -> u8 {
        let mut name = base.to_string();
        let mut k = 2;
        while self.list.contains(&name) {
            name = format!("{base}_{k}");
            k += 1;
        }
        self.list.push(name);
        // More than MAX_LIGHT_GROUPS are refused before any index is used.
        (self.list.len() - 1).min(NO_GROUP as usize - 1) as u8
    }
}
