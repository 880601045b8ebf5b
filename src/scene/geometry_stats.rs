//! What a scene's geometry costs: triangles stored (each glTF primitive once) against
//! triangles instanced (every placement counted), the bytes of the flat arrays and of the
//! acceleration structures, and how long loading and building took. `brume info` and
//! `brume render` print it, so the cost of production geometry is measured where it is paid.
use std::collections::HashMap;

use super::{Instance, Scene, Triangle, Vertex};

/// Wall-clock seconds of a scene's load.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoadTimings {
    /// Everything before the BVH: the file, its buffers, nodes, meshes flattened to world
    /// space, materials, textures, lights and the media's descriptions.
    pub read_seconds: f64,
    /// Building the scene's first accelerator: the two-level BVH where some primitive is
    /// placed more than once and no mesh moves, else the BVH over the world-space triangles.
    pub bvh_seconds: f64,
}

/// Counts and bytes of a scene's geometry.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GeometryStats {
    /// Distinct glTF primitives placed at least once.
    pub primitives: usize,
    /// Placements of primitives (`Scene::instances`).
    pub placements: usize,
    /// Triangles of the distinct primitives, each counted once.
    pub stored_triangles: usize,
    /// Triangles in the world, every placement counted (`Scene::triangles`).
    pub instanced_triangles: usize,
    /// World-space vertices, every placement counted.
    pub vertices: usize,
    /// Bytes of the instance records and of the world-space vertex and triangle arrays where
    /// they have been built (`Scene::world_arrays_built`).
    pub array_bytes: usize,
    /// Bytes of the stored primitives (each in its local space, once) kept to place triangles
    /// from where the world arrays wait for first use.
    pub stored_bytes: usize,
    /// Bytes of the flat BVH (nodes, primitive indices and triangle corners), where it has
    /// been built.
    pub bvh_bytes: usize,
    /// Bytes of the two-level BVH (each primitive's BVH and corners once, the placements and
    /// their top-level BVH), where the scene has one.
    pub two_level_bytes: Option<usize>,
    /// Bytes Embree allocated, where it was built.
    pub embree_bytes: Option<usize>,
}

impl GeometryStats {
    /// The stats of `scene` as loaded (and with Embree where [`Scene::use_accel`] built it).
    pub fn of(scene: &Scene) -> Self {
        let mut distinct: HashMap<(u32, u32), u32> = HashMap::new();
        for i in &scene.instances {
            distinct.insert((i.mesh, i.primitive), i.triangle_count);
        }
        let world = if scene.world_arrays_built() {
            std::mem::size_of::<Vertex>() * scene.vertex_count()
                + std::mem::size_of::<Triangle>() * scene.triangle_count()
        } else {
            0
        };
        let size = world + std::mem::size_of::<Instance>() * scene.instances.len();
        Self {
            primitives: distinct.len(),
            placements: scene.instances.len(),
            stored_triangles: distinct.values().map(|&n| n as usize).sum(),
            instanced_triangles: scene.triangle_count(),
            vertices: scene.vertex_count(),
            array_bytes: size,
            stored_bytes: scene.stored_primitive_bytes(),
            bvh_bytes: scene.built_flat_bvh().map_or(0, |b| b.memory_bytes()),
            two_level_bytes: scene.instanced.as_ref().map(|i| i.memory_bytes()),
            embree_bytes: scene
                .embree
                .as_ref()
                .map(|e| e.memory_bytes().max(0) as usize),
        }
    }

    /// Bytes of the geometry in memory: the arrays, the BVHs and Embree's scene.
    pub fn total_bytes(&self) -> usize {
        self.array_bytes
            + self.stored_bytes
            + self.bvh_bytes
            + self.two_level_bytes.unwrap_or(0)
            + self.embree_bytes.unwrap_or(0)
    }

    /// Two lines for people: the triangle counts, then the memory and the load's timings.
    pub fn report(&self, timings: &LoadTimings) -> String {
        let mib = |b: usize| b as f64 / (1 << 20) as f64;
        let per = |n: usize| self.total_bytes() as f64 / n.max(1) as f64;
        let embree = self
            .embree_bytes
            .map_or(String::new(), |b| format!(" + {:.1} MiB Embree", mib(b)));
        let two_level = self.two_level_bytes.map_or(String::new(), |b| {
            format!(" + {:.1} MiB two-level BVH", mib(b))
        });
        let stored = match self.stored_bytes {
            0 => String::new(),
            b => format!(" + {:.1} MiB stored primitives", mib(b)),
        };
        format!(
            "triangles: {} stored ({} primitives, each once), {} instanced ({} placements, \
             each placed in world space), {} vertices\n\
             geometry memory: {:.1} MiB arrays{stored} + {:.1} MiB BVH{two_level}{embree} = \
             {:.1} MiB ({:.0} bytes per stored triangle, {:.0} per instanced one); \
             loaded in {:.2} s, BVH built in {:.2} s",
            self.stored_triangles,
            self.primitives,
            self.instanced_triangles,
            self.placements,
            self.vertices,
            mib(self.array_bytes),
            mib(self.bvh_bytes),
            mib(self.total_bytes()),
            per(self.stored_triangles),
            per(self.instanced_triangles),
            timings.read_seconds,
            timings.bvh_seconds,
        )
    }
}
