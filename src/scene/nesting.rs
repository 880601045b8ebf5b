//! How a scene's media sit relative to one another: VDB media whose supports overlap, VDB
//! media inside (or across) the closed mesh of a `KHR_materials_volume` medium, and closed
//! media meshes nested in one another, with the depth of that nesting (the medium stack a path
//! needs, see `render::stack`). Computed once per scene from world bounds and the
//! parity test of [`Scene::inside_instance`].
use glam::Vec3;

use super::Scene;
use crate::math::Aabb;
use crate::scene::NO_INDEX;

/// One closed mesh instance bounding a homogeneous medium with non-zero extinction.
#[derive(Clone, Debug, PartialEq)]
pub struct MediumMesh {
    /// Index into `Scene::instances`.
    pub instance: usize,
    /// Index into `Scene::homogeneous_media`.
    pub medium: u32,
    pub bounds: Aabb,
    /// How many media meshes (this one included) a point just inside it is in.
    pub depth: usize,
}

/// The media layout of a scene (see the module doc).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Nesting {
    /// Two `BRUME_medium_vdb` media whose world bounds overlap.
    pub overlapping: bool,
    /// A VDB medium overlapping a media mesh, or a media mesh inside another.
    pub nested: bool,
    pub meshes: Vec<MediumMesh>,
    /// The media around the camera, outermost first.
    pub camera: Vec<u32>,
}

fn overlaps(a: &Aabb, b: &Aabb) -> bool {
    !a.is_empty() && !b.is_empty() && a.min.cmplt(b.max).all() && b.min.cmplt(a.max).all()
}

fn contains(outer: &Aabb, inner: &Aabb) -> bool {
    !outer.is_empty() && outer.min.cmple(inner.min).all() && inner.max.cmple(outer.max).all()
}

impl Nesting {
    pub fn of(scene: &Scene) -> Nesting {
        let vdb: Vec<Aabb> = scene
            .vdb_media
            .iter()
            .filter(|m| m.rendered())
            .map(|m| m.world_bounds)
            .collect();
        let overlapping = vdb
            .iter()
            .enumerate()
            .any(|(i, a)| vdb[i + 1..].iter().any(|b| overlaps(a, b)));
        let mut meshes = Vec::new();
        for (k, inst) in scene.instances.iter().enumerate() {
            let medium = scene.materials[inst.material as usize].interior_medium;
            let Some(h) = scene.homogeneous_media.get(medium as usize) else {
                continue;
            };
            if medium == NO_INDEX || (0..3).all(|c| h.sigma_a[c] + h.sigma_s[c] <= 0.0) {
                continue;
            }
            let first = inst.first_triangle as usize;
            let last = first + inst.triangle_count as usize;
            let bounds = (first..last)
                .flat_map(|t| scene.triangle_corners(t))
                .fold(Aabb::EMPTY, |b, p| b.union_point(p));
            meshes.push(MediumMesh {
                instance: k,
                medium,
                bounds,
                depth: 1,
            });
        }
        // A mesh is inside another when its box is and one of its vertices is (meshes do not
        // intersect in a valid scene, so one vertex decides).
        let probe = |m: &MediumMesh| -> Option<Vec3> {
            let inst = &scene.instances[m.instance];
            (inst.triangle_count > 0)
                .then(|| scene.triangle_corners(inst.first_triangle as usize)[0])
        };
        let depths: Vec<usize> = meshes
            .iter()
            .map(|m| {
                let p = probe(m);
                1 + meshes
                    .iter()
                    .filter(|o| o.instance != m.instance && contains(&o.bounds, &m.bounds))
                    .filter(|o| p.is_some_and(|p| scene.inside_instance(p, o.instance)))
                    .count()
            })
            .collect();
        for (m, d) in meshes.iter_mut().zip(depths) {
            m.depth = d;
        }
        let nested = meshes.iter().any(|m| m.depth > 1)
            || vdb
                .iter()
                .any(|v| meshes.iter().any(|m| overlaps(v, &m.bounds)));
        let cam = scene.camera.position();
        let mut around: Vec<&MediumMesh> = meshes
            .iter()
            .filter(|m| scene.inside_instance(cam, m.instance))
            .collect();
        around.sort_by_key(|m| m.depth);
        let camera = around.iter().map(|m| m.medium).collect();
        Nesting {
            overlapping,
            nested,
            meshes,
            camera,
        }
    }

    /// The most deeply nested media mesh, if any.
    pub fn deepest(&self) -> Option<&MediumMesh> {
        self.meshes.iter().max_by_key(|m| m.depth)
    }
}
