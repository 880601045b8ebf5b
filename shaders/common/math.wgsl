// Mirrors f32::ln (glibc/musl logf) as used by tracking::sample_exponential
// (src/volume/tracking/mod.rs): an accurate natural logarithm.
//
// WGSL's log() only has to meet Vulkan's precision rule, an ABSOLUTE error of 2^-21 on
// [0.5, 2]: near 1, where -ln(1 - u) for a small uniform u sets the length of a short
// exponential step, that is a large relative error. This is the FreeBSD/musl `logf`
// (argument reduction to [sqrt(2)/2, sqrt(2)), a degree-8 odd polynomial in s = f / (2 + f);
// error below 1 ulp), so GPU steps agree with the CPU's to an ulp or so instead.
// Valid for positive normal x, which is all the tracking code passes (1 - u >= 2^-24).

const LN2_HI: f32 = 6.9313812256e-01;
const LN2_LO: f32 = 9.0580006145e-06;
const LG1: f32 = 0.66666662693;
const LG2: f32 = 0.40000972152;
const LG3: f32 = 0.28498786688;
const LG4: f32 = 0.24279078841;

fn ln_f32(x_in: f32) -> f32 {
    var ix = bitcast<u32>(x_in);
    // Reduce x into [sqrt(2)/2, sqrt(2)) times 2^k.
    ix += 0x3f800000u - 0x3f3504f3u;
    let k = i32(ix >> 23u) - 0x7f;
    ix = (ix & 0x007fffffu) + 0x3f3504f3u;
    let f = bitcast<f32>(ix) - 1.0;
    let s = f / (2.0 + f);
    let z = s * s;
    let w = z * z;
    let t1 = w * (LG2 + w * LG4);
    let t2 = z * (LG1 + w * LG3);
    let r = t2 + t1;
    let hfsq = 0.5 * f * f;
    let dk = f32(k);
    return s * (hfsq + r) + dk * LN2_LO - hfsq + f + dk * LN2_HI;
}
