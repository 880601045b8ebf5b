//! The human-readable scene summary printed by `brume info`.
use std::fmt::Write;

use super::lights::{LIGHT_DIRECTIONAL, LIGHT_POINT};
use super::{CameraSource, Scene};

pub fn summary(s: &Scene) -> String {
    let mut o = String::new();
    let _ = write_summary(s, &mut o);
    o
}

fn write_summary(s: &Scene, o: &mut String) -> std::fmt::Result {
    writeln!(o, "scene {}", s.source.display())?;
    let c = &s.camera;
    let origin = match &c.source {
        CameraSource::Node { node, camera } => format!("camera {camera} on node {node}"),
        CameraSource::Default => "default camera framing the bounds".to_string(),
    };
    writeln!(
        o,
        "camera: {} ({origin}), position {:.3}, forward {:.3}, yfov {:.2} deg, znear {}",
        c.name.as_deref().unwrap_or("unnamed"),
        c.position(),
        c.forward(),
        c.yfov.to_degrees(),
        c.znear
    )?;
    for e in &s.cameras {
        writeln!(
            o,
            "  in file: {} (camera {}, node {}, {})",
            e.name.as_deref().unwrap_or("unnamed"),
            e.camera,
            e.node,
            if e.perspective {
                "perspective"
            } else {
                "orthographic, unsupported"
            }
        )?;
    }
    writeln!(
        o,
        "meshes: {} instances, {} triangles, {} vertices",
        s.instances.len(),
        s.triangle_count(),
        s.vertex_count()
    )?;
    writeln!(
        o,
        "materials: {} (incl. the glTF default), {} textures referenced",
        s.materials.len(),
        s.textures.len()
    )?;
    for (m, name) in s.materials.iter().zip(&s.material_names) {
        writeln!(
            o,
            "  {}: base {:?}, metallic {}, roughness {}, emission {:?}, transmission {}",
            name.as_deref().unwrap_or("unnamed"),
            m.base_color,
            m.metallic,
            m.roughness,
            m.emission,
            m.transmission
        )?;
    }
    writeln!(o, "lights: {}", s.lights.len())?;
    for l in &s.lights {
        let kind = match l.kind {
            LIGHT_POINT => "point",
            LIGHT_DIRECTIONAL => "directional",
            _ => "spot",
        };
        writeln!(
            o,
            "  {kind}: intensity {:?}, position {:?}, direction {:?}",
            l.intensity, l.position, l.direction
        )?;
    }
    writeln!(
        o,
        "environment: radiance {:?}{}",
        s.environment.radiance,
        s.environment.map.as_ref().map_or(String::new(), |p| {
            let (w, h) = s
                .environment
                .image
                .as_ref()
                .map_or((0, 0), |m| (m.width, m.height));
            format!(
                ", map {} ({w}x{h}), rotation {:?}",
                p.display(),
                s.environment.rotation
            )
        })
    )?;
    write_media(s, o)?;
    writeln!(o, "effects: {}", s.effects().names().join(", "))?;
    for w in &s.warnings {
        writeln!(o, "warning: {w}")?;
    }
    Ok(())
}

/// The frame (for animations and sequences) and the media.
fn write_media(s: &Scene, o: &mut String) -> std::fmt::Result {
    let sequences = s
        .vdb_media
        .iter()
        .filter(|m| super::sequence::is_sequence(&m.uri))
        .count();
    if sequences > 0 || s.animated_nodes > 0 {
        writeln!(
            o,
            "frame {} at {} fps: {} animated node(s), {sequences} medium file sequence(s)",
            s.frame, s.fps, s.animated_nodes
        )?;
    }
    if let Some((a, b)) = s.render.frame_range {
        writeln!(o, "shot: frames {a}..{b} (--frames scene renders them)")?;
    }
    if s.shutter.is_open() {
        let camera = match &s.camera_motion {
            Some(m) => format!("the camera moves ({} poses across it)", m.poses.len()),
            None => "the camera stands still".into(),
        };
        let media = s.vdb_media.iter().filter(|m| m.motion.is_some()).count();
        let lights = s.light_motion.iter().filter(|m| m.is_some()).count();
        let meshes = s.moving_meshes.as_ref().map_or(0, |m| m.meshes.len());
        let camera = format!(
            "{camera}, {meshes} mesh instance(s), {media} medium node(s) and {lights} light(s) move"
        );
        writeln!(
            o,
            "shutter: {} to {} frames around the frame ({} fps); {camera}",
            s.shutter.open, s.shutter.close, s.fps
        )?;
    }
    writeln!(
        o,
        "media: {} homogeneous, {} VDB",
        s.homogeneous_media.len(),
        s.vdb_media.len()
    )?;
    for m in &s.homogeneous_media {
        let phase = match m.phase.henyey_greenstein_g() {
            Some(g) => format!("g {g}"),
            None => format!("phase {}", m.phase.name()),
        };
        writeln!(
            o,
            "  homogeneous (material {}): sigma_a {:?}, sigma_s {:?}, {phase}",
            m.material, m.sigma_a, m.sigma_s
        )?;
    }
    for m in &s.vdb_media {
        let grids: Vec<&str> = m.grids.iter().map(|g| g.name.as_str()).collect();
        writeln!(
            o,
            "  vdb {} (node {}): grids {:?}, sigma_t per density {:?}, g {}, emits {}, bounds {:?} ({:?})",
            m.vdb_path.display(),
            m.node,
            grids,
            m.sigma_t_per_density(),
            m.anisotropy,
            m.emits(),
            m.world_bounds,
            m.bounds_source
        )?;
        if let Some(v) = &m.velocity {
            let g = &v.grid;
            let factor = v.factor(s.shutter, s.fps);
            let blur = if factor == 0.0 {
                "no blur (shutter closed or scale 0)".to_string()
            } else {
                format!(
                    "blur up to {:.1} voxels from the frame",
                    g.max_index_speed() * (factor * s.shutter.max_offset()) as f64
                )
            };
            writeln!(
                o,
                "    velocity {:?} ({}, per {}, scale {}): max speed {:.4} per {}, {blur}",
                v.grid_name,
                if g.staggered {
                    "staggered"
                } else {
                    "cell-centred"
                },
                v.unit.name(),
                v.scale,
                g.speed.max_speed(),
                v.unit.name()
            )?;
        }
    }
    Ok(())
}
