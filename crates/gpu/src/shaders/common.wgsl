// Shared prelude of every rayspace kernel: the launch-parameter block, linear thread ids,
// and the vector and elementary functions in exactly the evaluation order of the CPU code
// (glam's scalar Vec3 and geom::pmath), so that any device computes the same bits as the CPU
// engines: products, partial sums, ÷ and sqrt are guarded below against the fusing,
// algebra and approximations a driver's compiler may apply (checked on lavapipe and on an
// NVIDIA H100). Constants that are not exact literals are
// injected by the host as bit patterns (see `kernels.rs`), never written as decimal
// literals, because WGSL folds literal expressions in f64 (abstract float) while Rust folds
// them in f32.

// The launch-parameter block: 16 u32 and 8 f32 (f1.w the opaque zero below). Kernels read
// it through their module's `struct …Params`, whose accessor build.rs generates (the Rust
// side packs the same struct at the same offsets: kernels.rs, `params`).
struct Params {
    u0: vec4<u32>,
    u1: vec4<u32>,
    u2: vec4<u32>,
    u3: vec4<u32>,
    f0: vec4<f32>,
    f1: vec4<f32>,
}

@group(0) @binding(0) var<uniform> P: Params;

const WG: u32 = 256u;

// Linear workgroup index of a (possibly 2-D folded) dispatch.
fn wg_linear(wid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return wid.x + wid.y * nwg.x;
}

// f32 → u32 keys whose unsigned order is the floats' order (for atomicMin / atomicMax of
// floats), and back.
fn order_key(x: f32) -> u32 {
    let b = bitcast<u32>(x);
    if (b & 0x80000000u) != 0u {
        return ~b;
    }
    return b | 0x80000000u;
}

fn unorder_key(k: u32) -> f32 {
    if (k & 0x80000000u) != 0u {
        return bitcast<f32>(k & 0x7fffffffu);
    }
    return bitcast<f32>(~k);
}

// --- values kept as written ---
// keep(x): x computed as written before it is used. OR-ing in a zero the compiler cannot see
// (P.f1.w, set to 0 by the host for every launch) makes x a value of its own, so that:
// - a product that feeds a sum is not fused with it into one FMA (one rounding instead of
//   two; lavapipe fuses when the product has a single use): such products go through mul();
// - a compiler's algebra does not change the rounding: NVIDIA's rewrote (x + K1) · K2 with
//   constants K1, K2 into fma(x, K2, K1·K2) (on an H100 that moved 25 of 2^20 ray-hash keys
//   by one step) and ((x − a) − b) − c into x − (a + b + c) (a cone's cos α off by one ulp).
//   So every sum of three or more terms keeps its partial sums, and a sum that a constant
//   multiplies is kept.
// f64 has no 32-bit bitcast; there a select on the opaque zero does the same.
fn opaque_zero() -> u32 {
    return bitcast<u32>(P.f1.w);
}

fn keep(x: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(x) | opaque_zero());
}

fn mul(a: f32, b: f32) -> f32 {
    return keep(a * b);
}

fn mul3(a: vec3<f32>, b: f32) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(a * b) | vec3<u32>(opaque_zero()));
}

fn keep64(x: f64) -> f64 {
    return select(x, 0.0lf, opaque_zero() != 0u);
}

fn keep3_64(x: vec3<f64>) -> vec3<f64> {
    return select(x, vec3<f64>(0.0lf), opaque_zero() != 0u);
}

fn mul64(a: f64, b: f64) -> f64 {
    return keep64(a * b);
}

fn mul3_64(a: vec3<f64>, b: f64) -> vec3<f64> {
    return keep3_64(a * b);
}

// --- correctly rounded division and square root ---
// Vulkan lets a driver compute an f32 x / y within 2.5 ulp and sqrt within 3 ulp, and
// NVIDIA's do (on an H100 the hits and shadow directions differed from the CPU's in their last
// bits), while the CPU's are correctly rounded. Computed in f64 and rounded once to f32, they
// are correctly rounded again: an f32 quotient a/b cannot lie within 2^-48 (relative) of an
// f32 rounding boundary without being on it (a - m·b is a non-zero multiple of the product's
// last place, because m's odd 25-bit significand times b's cannot equal a's 24-bit one), and
// a square root not within 2^-50 likewise, while f64 arithmetic errs by 2^-52 at most. The
// WGSL `/` and `sqrt` are never used on f32 values in the kernels that must match the CPU.
fn div(a: f32, b: f32) -> f32 {
    return f32(f64(a) / f64(b));
}

fn div3(a: vec3<f32>, b: f32) -> vec3<f32> {
    return vec3<f32>(vec3<f64>(a) / f64(b));
}

fn div3v(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(vec3<f64>(a) / vec3<f64>(b));
}

fn sqrt32(x: f32) -> f32 {
    return f32(sqrt(f64(x)));
}

// f64 ÷ and sqrt themselves, correctly rounded as the CPU's are, for f64 results that are
// rounded to f32 afterwards (the minimal ball's centre): a value within an ulp of an f32
// rounding boundary would otherwise round the other way (a regular grid of ray origins
// makes such values). One Newton step on the exact residual (fma) corrects a quotient or
// root that is off by an ulp; a correctly rounded one stays as it is, since its correction
// is below half an ulp and a quotient or root of floats is never exactly halfway. This is
// the suspected cause of the one minimal-ball node that was an f32 ulp off on an H100 and
// an H200 (bench/results/2026-11-28-h200); no real GPU has run the fix yet (lavapipe's
// f64 ÷ and sqrt are already correctly rounded, so it cannot show the difference).
fn div64(a: f64, b: f64) -> f64 {
    let q = a / b;
    let r = fma(-q, b, a);
    return keep64(q + r / b);
}

fn div3_64(a: vec3<f64>, b: f64) -> vec3<f64> {
    return vec3<f64>(div64(a.x, b), div64(a.y, b), div64(a.z, b));
}

fn sqrt64(x: f64) -> f64 {
    let s = sqrt(x);
    if s == 0.0lf {
        return s;
    }
    let r = fma(-s, s, x);
    return keep64(s + r / (2.0lf * s));
}

// --- glam Vec3, scalar implementation order ---
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    let xx = mul(a.x, b.x);
    let yy = mul(a.y, b.y);
    let zz = mul(a.z, b.z);
    return keep(xx + yy) + zz;
}

fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    let x = mul(a.y, b.z) - mul(b.y, a.z);
    let y = mul(a.z, b.x) - mul(b.z, a.x);
    let z = mul(a.x, b.y) - mul(b.x, a.y);
    return vec3<f32>(x, y, z);
}

fn len3(a: vec3<f32>) -> f32 {
    return sqrt32(dot3(a, a));
}

fn normalize3(a: vec3<f32>) -> vec3<f32> {
    let rcp = div(1.0, len3(a));
    return a * rcp;
}

// glam's normalize_or_zero: the reciprocal length must be finite and positive.
fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn normalize_or_zero3(a: vec3<f32>) -> vec3<f32> {
    let rcp = div(1.0, len3(a));
    if is_finite(rcp) && rcp > 0.0 {
        return a * rcp;
    }
    return vec3<f32>(0.0);
}

fn max_element3(a: vec3<f32>) -> f32 {
    return max(max(a.x, a.y), a.z);
}

// --- geom::pmath ---
fn p_atan(x0: f32) -> f32 {
    let neg = x0 < 0.0;
    var x = abs(x0);
    var y0 = 0.0;
    if x > C_T3P8 {
        x = -div(1.0, x);
        y0 = C_FRAC_PI_2;
    } else if x > C_TP8 {
        x = div(x - 1.0, x + 1.0);
        y0 = C_FRAC_PI_4;
    }
    let z = x * x;
    var p = mul(C_AT0, z) - C_AT1;
    p = mul(p, z) + C_AT2;
    p = mul(p, z) - C_AT3;
    p = mul(p, z);
    let y = keep(y0 + keep(mul(p, x) + x));
    if neg {
        return -y;
    }
    return y;
}

fn p_atan2(y: f32, x: f32) -> f32 {
    if x == 0.0 {
        if y > 0.0 {
            return C_FRAC_PI_2;
        } else if y < 0.0 {
            return -C_FRAC_PI_2;
        }
        return 0.0;
    }
    if y == 0.0 {
        if x > 0.0 {
            return 0.0;
        }
        return C_PI;
    }
    let a = p_atan(div(y, x));
    if x > 0.0 {
        return a;
    } else if y > 0.0 {
        return keep(a + C_PI);
    }
    return keep(a - C_PI);
}

fn p_acos(x0: f32) -> f32 {
    let x = clamp(x0, -1.0, 1.0);
    return p_atan2(sqrt32(keep(1.0 - x) * keep(1.0 + x)), x);
}

// (sin x, cos x)
fn p_sin_cos(x: f32) -> vec2<f32> {
    let qf = floor(mul(x, C_TWO_OVER_PI) + 0.5);
    let r = keep(keep(x - mul(qf, C_DP1)) - mul(qf, C_DP2)) - mul(qf, C_DP3);
    let z = r * r;
    var ts = mul(-C_S0, z) + C_S1;
    ts = mul(ts, z) - C_S2;
    let s = mul(mul(ts, z), r) + r;
    var tc = mul(C_C0, z) - C_C1;
    tc = mul(tc, z) + C_C2;
    let c = keep(mul(mul(tc, z), z) - mul(0.5, z)) + 1.0;
    let q = i32(qf) & 3;
    if q == 0 {
        return vec2<f32>(s, c);
    } else if q == 1 {
        return vec2<f32>(c, -s);
    } else if q == 2 {
        return vec2<f32>(-s, -c);
    }
    return vec2<f32>(-c, s);
}
