"""Render a Brume scene with Mitsuba 3, from the description `brume mitsuba` writes.

Usage (normally run by `brume mitsuba`; tools/mitsuba/setup.sh installs the venv):

    tools/mitsuba/.venv/bin/python brume_to_mitsuba.py scene.json -o out.exr [--variant V]

`scene.json` is written by `src/cli/mitsuba.rs` from Brume's own loaded scene, with Brume's
mappings already applied (Principled Volume coefficients, light units, materials); the VDB
media come as `.vol` grids and the meshes as world-space PLY files next to it. This script only
builds Mitsuba's scene dictionary and renders `runs` seeds (seed .. seed + runs - 1), writing
`out.run<k>.exr` for each and printing `render_seconds <k> <s> <path>`; `build_seconds` is the
scene set-up (mi.load_dict), reported apart from the render times.

Mapping (docs/comparing.md):
- integrator `volpath`, max_depth from the JSON (Brume's + 1), rr_depth Mitsuba's default (5);
- sensor `perspective`, vertical field of view (fov_axis y) at the render's aspect, near clip
  = glTF znear, look-at from Brume's camera; `independent` sampler; `hdrfilm` with a `box`
  filter (each sample lands in its own pixel, Brume's uniform jitter), rgb, float32;
- VDB media: `heterogeneous` with sigma_t = `gridvolume` (the extinction per metre, already
  scaled), constant albedo, its phase (`hg`, `blendphase` of two `hg`, `rayleigh`), inside a
  `cube` with a `null` BSDF spanning the grid's box; the grid's and the cube's to_world is
  Brume's world_from_medium (index to world);
- meshes: PLY with `brume_opaque` (below), `dielectric` or `null` BSDFs, `area` emitters,
  `homogeneous` interiors for KHR_materials_volume (phases as for VDB media);
- lights: `point` (intensity W/sr), `brume_spot` (a Python emitter with glTF's falloff, as
  Brume), `directional` (irradiance W/m^2); the environment as a `constant` emitter;
- opaque surfaces: `brume_opaque`, Brume's Lambert + GGX model as a Python BSDF (or Mitsuba's
  `diffuse` with --lambert-only).
"""
import argparse
import json
import os
import sys
import time

import mitsuba as mi


def pick_variant(requested):
    """llvm_ad_rgb (JIT-compiled, vectorised) when it loads, else scalar_rgb."""
    wanted = [requested] if requested else ["llvm_ad_rgb", "scalar_rgb"]
    for v in wanted:
        try:
            mi.set_variant(v)
            return v
        except Exception as e:  # noqa: BLE001 - Dr.Jit raises plain errors without libLLVM
            if requested:
                sys.exit(f"error: Mitsuba variant {v} is not usable: {e}")
            print(
                f"note: Mitsuba variant {v} is not usable ({str(e).splitlines()[0]}); "
                "falling back (install libllvm19 for llvm_ad_rgb)",
                file=sys.stderr,
            )
    sys.exit("error: no Mitsuba variant could be loaded")


def register_brume_opaque():
    """Registers `brume_opaque`: Brume's opaque surface model (src/integrator/bsdf.rs), which
    Mitsuba has no plugin for: a Lambertian lobe `kd / pi` plus GGX reflection
    `F(wo.h) D(h) G2 / (4 cos_o cos_i)` with Schlick's Fresnel from `f0` and Smith's
    height-correlated masking `G2 = 1 / (1 + Lambda(wo) + Lambda(wi))`, added without energy
    compensation, two-sided (evaluated on the side `si.wi` is on). Parameters come from Brume's
    own `Principled::new` via the JSON: kd, f0, alpha, p_spec (probability of sampling the
    GGX lobe by its distribution of normals; else cosine-weighted)."""
    import drjit as dr

    class BrumeOpaque(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.kd = mi.Color3f(*[props[f"kd{c}"] for c in "rgb"])
            self.f0 = mi.Color3f(*[props[f"f0{c}"] for c in "rgb"])
            self.alpha = float(props["alpha"])
            self.p_spec = float(props["p_spec"])
            sides = mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
            diffuse = mi.BSDFFlags.DiffuseReflection | sides
            glossy = mi.BSDFFlags.GlossyReflection | sides
            self.m_components = [diffuse, glossy]
            self.m_flags = diffuse | glossy

        def _ggx_d(self, cos_h):
            a2 = self.alpha * self.alpha
            t = cos_h * cos_h * (a2 - 1.0) + 1.0
            return a2 / (dr.pi * t * t)

        def _lambda(self, cos):
            c2 = dr.maximum(cos * cos, 1e-12)
            return 0.5 * (dr.sqrt(1.0 + self.alpha * self.alpha * (1.0 - c2) / c2) - 1.0)

        def _value_pdf(self, wi, wo):
            """f * cos(wo) and the sampling pdf, both directions on the +z side."""
            valid = (wi.z > 0) & (wo.z > 0)
            h = dr.normalize(wi + wo)
            g2 = 1.0 / (1.0 + self._lambda(wi.z) + self._lambda(wo.z))
            m = 1.0 - dr.clip(dr.dot(wi, h), 0.0, 1.0)
            fresnel = self.f0 + (1.0 - self.f0) * (m * m * m * m * m)
            d = self._ggx_d(h.z)
            # Guarded denominators: the scalar variants raise on a division by zero, and the
            # invalid cases are masked below anyway.
            f = self.kd / dr.pi + fresnel * (d * g2 / dr.maximum(4.0 * wi.z * wo.z, 1e-12))
            pdf_spec = d * h.z / (4.0 * dr.maximum(dr.dot(wi, h), 1e-8))
            pdf = self.p_spec * pdf_spec + (1.0 - self.p_spec) * wo.z / dr.pi
            return dr.select(valid, f * wo.z, 0.0), dr.select(valid, pdf, 0.0)

        @staticmethod
        def _upper(si, wo):
            """Both directions mirrored to the side si.wi is on, and the sign used."""
            sign = dr.select(si.wi.z < 0, -1.0, 1.0)
            wi = mi.Vector3f(si.wi.x, si.wi.y, si.wi.z * sign)
            return wi, mi.Vector3f(wo.x, wo.y, wo.z * sign), sign

        def eval(self, ctx, si, wo, active=True):
            wi, wo, _ = self._upper(si, wo)
            return self._value_pdf(wi, wo)[0]

        def pdf(self, ctx, si, wo, active=True):
            wi, wo, _ = self._upper(si, wo)
            return self._value_pdf(wi, wo)[1]

        def eval_pdf(self, ctx, si, wo, active=True):
            wi, wo, _ = self._upper(si, wo)
            return self._value_pdf(wi, wo)

        def sample(self, ctx, si, sample1, sample2, active=True):
            wi, _, sign = self._upper(si, si.wi)
            spec = sample1 < self.p_spec
            # GGX normals with density D(h) cos(h): cos^2 = (1 - u) / (1 + (a^2 - 1) u).
            a2 = self.alpha * self.alpha
            cos2 = (1.0 - sample2.x) / (1.0 + (a2 - 1.0) * sample2.x)
            sin_h = dr.sqrt(dr.maximum(1.0 - cos2, 0.0))
            phi = 2.0 * dr.pi * sample2.y
            h = mi.Vector3f(sin_h * dr.cos(phi), sin_h * dr.sin(phi), dr.sqrt(cos2))
            wo_spec = 2.0 * dr.dot(wi, h) * h - wi
            wo_diff = mi.warp.square_to_cosine_hemisphere(sample2)
            wo = dr.select(spec, wo_spec, wo_diff)
            value, pdf = self._value_pdf(wi, wo)
            ok = active & (wo.z > 0) & (pdf > 0)
            bs = mi.BSDFSample3f()
            bs.wo = mi.Vector3f(wo.x, wo.y, wo.z * sign)
            bs.pdf = dr.select(ok, pdf, 0.0)
            bs.eta = 1.0
            bs.sampled_type = dr.select(
                spec,
                mi.UInt32(+mi.BSDFFlags.GlossyReflection),
                mi.UInt32(+mi.BSDFFlags.DiffuseReflection),
            )
            bs.sampled_component = dr.select(spec, mi.UInt32(1), mi.UInt32(0))
            return bs, dr.select(ok, value / dr.select(ok, pdf, 1.0), 0.0)

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return f"BrumeOpaque[kd={self.kd}, f0={self.f0}, alpha={self.alpha}]"

    mi.register_bsdf("brume_opaque", lambda props: BrumeOpaque(props))


def register_brume_spot():
    """Registers `brume_spot`: a glTF spot light as Brume lights it (src/render/lights.rs),
    radiant intensity `I * a^2` with `a = clamp((cos - cos_outer) / (cos_inner - cos_outer))`
    (denominator at least 1e-3). Mitsuba's own `spot` falls off linearly in the angle, which
    differs in the penumbra. A point-like (delta position) emitter: only sampled towards a
    receiver, never hit."""
    import drjit as dr

    class BrumeSpot(mi.Emitter):
        def __init__(self, props):
            mi.Emitter.__init__(self, props)
            self.position = mi.Point3f(*[props[f"p{c}"] for c in "xyz"])
            self.axis = mi.Vector3f(*[props[f"d{c}"] for c in "xyz"])
            self.intensity = mi.Color3f(*[props[f"i{c}"] for c in "rgb"])
            self.cos_inner = float(props["cos_inner"])
            self.cos_outer = float(props["cos_outer"])
            # Scalar types have no Scalar prefix in the scalar variants.
            box, point = (getattr(mi, "Scalar" + n, getattr(mi, n)) for n in ("BoundingBox3f", "Point3f"))
            self.box = box(point(*[props[f"p{c}"] for c in "xyz"]))
            self.m_flags = mi.EmitterFlags.DeltaPosition

        def _radiant_intensity(self, d_from_light):
            scale = 1.0 / max(self.cos_inner - self.cos_outer, 1e-3)
            a = dr.clip((dr.dot(self.axis, d_from_light) - self.cos_outer) * scale, 0.0, 1.0)
            return self.intensity * (a * a)

        def sample_direction(self, it, sample, active=True):
            ds = mi.DirectionSample3f()
            d = self.position - it.p
            dist2 = dr.maximum(dr.squared_norm(d), 1e-20)
            dist = dr.sqrt(dist2)
            ds.p = self.position
            ds.n = mi.Normal3f(0.0)
            ds.uv = mi.Point2f(0.0)
            ds.time = it.time
            ds.pdf = 1.0
            ds.delta = True
            ds.d = d / dist
            ds.dist = dist
            # A pointer type in the JIT variants, the object itself in the scalar ones.
            ds.emitter = mi.EmitterPtr(self) if hasattr(mi, "EmitterPtr") else self
            return ds, self._radiant_intensity(-ds.d) / dist2

        def pdf_direction(self, it, ds, active=True):
            return mi.Float(0.0)

        def eval_direction(self, it, ds, active=True):
            return mi.Color3f(0.0)

        def eval(self, si, active=True):
            return mi.Color3f(0.0)

        def sample_ray(self, time, sample1, sample2, sample3, active=True):
            # Light tracing is not used by volpath; a ray from the light with no weight.
            return mi.Ray3f(self.position, self.axis, time), mi.Color3f(0.0)

        def bbox(self):
            return self.box

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return f"BrumeSpot[intensity={self.intensity}]"

    mi.register_emitter("brume_spot", lambda props: BrumeSpot(props))


def rgb(v):
    return {"type": "rgb", "value": [float(c) for c in v]}


def transform(rows):
    return mi.ScalarTransform4f(rows)


def extinction_texture(m):
    """The `gridvolume` of one VDB medium: the .vol holds sigma_t per metre at voxel centres.
    Mitsuba 3.9 ignores the box in the file's header (measured: the texture spans the unit
    cube of its to_world), so to_world maps the unit cube onto the box in index space
    (box_min, box_max), then index space to the world (Brume's world_from_medium)."""
    T = mi.ScalarTransform4f
    lo, hi = m["box_min"], m["box_max"]
    extent = [b - a for a, b in zip(lo, hi)]
    return {
        "type": "gridvolume",
        "filename": os.path.abspath(m["vol"]),
        "to_world": transform(m["to_world"]) @ T().translate(lo) @ T().scale(extent),
        "filter_type": "trilinear",
        "wrap_mode": "clamp",
        "raw": True,
    }


def build(desc):
    T = mi.ScalarTransform4f
    cam = desc["camera"]
    scene = {
        "type": "scene",
        "integrator": {"type": "volpath", "max_depth": int(desc["max_depth"])},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": float(cam["yfov_degrees"]),
            "near_clip": float(cam["near_clip"]),
            "far_clip": 1e7,
            "to_world": T().look_at(origin=cam["origin"], target=cam["target"], up=cam["up"]),
            "sampler": {"type": "independent", "sample_count": int(desc["spp"])},
            "film": {
                "type": "hdrfilm",
                "width": int(desc["width"]),
                "height": int(desc["height"]),
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
                "component_format": "float32",
            },
        },
    }
    for i, l in enumerate(desc["lights"]):
        if l["type"] == "point":
            e = {"type": "point", "position": l["position"], "intensity": rgb(l["intensity"])}
        elif l["type"] == "spot":
            e = {"type": "brume_spot", "cos_inner": float(l["cos_inner"]),
                 "cos_outer": float(l["cos_outer"])}
            # Plugin properties are scalars here: one per component.
            for c, pos, axis in zip("xyz", l["position"], l["direction"]):
                e[f"p{c}"], e[f"d{c}"] = float(pos), float(axis)
            for c, intensity in zip("rgb", l["intensity"]):
                e[f"i{c}"] = float(intensity)
        elif l["type"] == "directional":
            e = {"type": "directional", "direction": l["direction"],
                 "irradiance": rgb(l["irradiance"])}
        else:
            sys.exit(f"error: unknown light type {l['type']}")
        scene[f"light{i}"] = e
    if desc.get("environment"):
        scene["environment"] = {"type": "constant", "radiance": rgb(desc["environment"])}

    for i, m in enumerate(desc["vdb_media"]):
        to_world = transform(m["to_world"])
        lo, hi = m["box_min"], m["box_max"]
        medium = {
            "type": "heterogeneous",
            "sigma_t": extinction_texture(m),
            "albedo": {"type": "constvolume", "value": rgb(m["albedo"])},
            "scale": 1.0,
            "phase": m.get("phase", {"type": "hg", "g": float(m["g"])}),
        }
        centre = [(a + b) / 2 for a, b in zip(lo, hi)]
        half = [(b - a) / 2 for a, b in zip(lo, hi)]
        scene[f"medium_box{i}"] = {
            "type": "cube",
            "to_world": to_world @ T().translate(centre) @ T().scale(half),
            "bsdf": {"type": "null"},
            "interior": medium,
        }

    for i, m in enumerate(desc["meshes"]):
        shape = {
            "type": "ply",
            "filename": os.path.abspath(m["ply"]),
            "face_normals": bool(m["face_normals"]),
        }
        b = m["bsdf"]
        if b["type"] == "brume_opaque":
            shape["bsdf"] = {"type": "brume_opaque", "alpha": float(b["alpha"]),
                             "p_spec": float(b["p_spec"])}
            for c, x, y in zip("rgb", b["kd"], b["f0"]):
                shape["bsdf"][f"kd{c}"] = float(x)
                shape["bsdf"][f"f0{c}"] = float(y)
        elif b["type"] == "diffuse":
            shape["bsdf"] = {"type": "diffuse", "reflectance": rgb(b["reflectance"])}
        elif b["type"] == "dielectric":
            shape["bsdf"] = {"type": "dielectric", "int_ior": float(b["ior"]), "ext_ior": 1.0}
        else:
            shape["bsdf"] = {"type": "null"}
        if "emission" in m:
            shape["emitter"] = {"type": "area", "radiance": rgb(m["emission"])}
        if "interior" in m:
            h = m["interior"]
            # Mitsuba takes RGB medium parameters as reflectance-like colours in [0, 1], so the
            # extinction goes in as a colour times a scale.
            scale = max(max(h["sigma_t"]), 1e-30)
            shape["interior"] = {
                "type": "homogeneous",
                "sigma_t": rgb([c / scale for c in h["sigma_t"]]),
                "scale": scale,
                "albedo": rgb(h["albedo"]),
                "phase": h.get("phase", {"type": "hg", "g": float(h.get("g", 0.0))}),
            }
        scene[f"mesh{i}"] = shape
    return scene


def main(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("description", help="scene.json written by `brume mitsuba`")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--variant", help="Mitsuba variant (default llvm_ad_rgb, else scalar_rgb)")
    args = p.parse_args(argv)
    with open(args.description) as f:
        desc = json.load(f)
    variant = pick_variant(args.variant)
    print(f"variant {variant}", flush=True)
    register_brume_opaque()
    register_brume_spot()
    import drjit as dr

    all_threads = dr.thread_count()
    render_threads = int(desc.get("threads") or all_threads)
    t0 = time.time()
    scene = mi.load_dict(build(desc))
    print(f"build_seconds {time.time() - t0:.3f}", flush=True)
    out = os.path.abspath(args.output)
    for k in range(int(desc["runs"])):
        dr.set_thread_count(render_threads)
        t = time.time()
        img = mi.render(scene, spp=int(desc["spp"]), seed=int(desc["seed"]) + k)
        dr.eval(img)
        bitmap = mi.Bitmap(img, pixel_format=mi.Bitmap.PixelFormat.RGB)
        seconds = time.time() - t
        # Writing an EXR with Dr.Jit's pool at one thread hangs (measured with Mitsuba 3.9.1,
        # llvm_ad_rgb): the writer gets the whole pool back.
        dr.set_thread_count(all_threads)
        path = f"{os.path.splitext(out)[0]}.run{k}.exr"
        bitmap.write(path)
        print(f"render_seconds {k} {seconds:.3f} {path}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
