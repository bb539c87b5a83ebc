// Stage 0 of a grid sweep: each pose of the chunk is decoded from its index where it is drawn, so
// the host packs and uploads no pose. CPU twin: GridTables::decode (src/projection/poses.rs), the
// same composition in f64. The grid's index is mixed radix over nine axes, the last fastest: the
// feature's range, azimuth, elevation in sonar 1; the place's range, azimuth, elevation in sonar 2
// (or the translation tx, ty, tz); roll, pitch, yaw. The host gives the chunk's first pose as its
// nine digits. Per axis value it gives three Real entries built in f64 (value, cos, sin of the
// value in degrees), so no trigonometry runs here. A pose is written as the splat stage reads it:
// rows of M = range * R * Rz(base azimuth) and t, as hi + lo pairs, and its plan. Dispatch
// (ceil(count / 64), 1, 1): thread c decodes pose first + c.

struct GridParams {
    // digits of the chunk's first pose, axis k at [k / 4][k % 4]
    first: array<vec4<u32>, 3>,
    // values per axis
    lens: array<vec4<u32>, 3>,
    // where axis k's entries start in table (three an axis value: value, cos, sin)
    offsets: array<vec4<u32>, 3>,
    count: u32,
    // 1: the second three axes are a placement in sonar 2 (else the translation)
    placement: u32,
    // 1: sonar 1 is an FLS (the arc is rotated by the feature's azimuth, else by 0)
    fls: u32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> grid: GridParams;
@group(0) @binding(1) var<storage, read> table: array<vec2<f32>>;
// the plan of each value of the feature's range axis, in the chunk's direction table: (azimuth
// offset, azimuth count, elevation offset, elevation count)
@group(0) @binding(2) var<storage, read> plans: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read_write> poses: array<Pose>;

// Returns entry `which` (0 value, 1 cos, 2 sin) of value d of axis k.
fn entry(k: u32, d: u32, which: u32) -> Real {
    return real(table[grid.offsets[k / 4u][k % 4u] + 3u * d + which]);
}

fn r_sub(a: Real, b: Real) -> Real {
    return r_add(a, r_neg(b));
}

// Returns the point (r cos e cos a, r cos e sin a, r sin e) of the entries of axes kr, ka, ke.
fn spherical(kr: u32, ka: u32, ke: u32, d: array<u32, 9>) -> array<Real, 3> {
    let r = entry(kr, d[kr], 0u);
    let ce = entry(ke, d[ke], 1u);
    let rce = r_mul(r, ce);
    return array<Real, 3>(
        r_mul(rce, entry(ka, d[ka], 1u)),
        r_mul(rce, entry(ka, d[ka], 2u)),
        r_mul(r, entry(ke, d[ke], 2u)),
    );
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = gid.x;
    if c >= grid.count {
        return;
    }
    // The digits of first + c, carried from the last axis.
    var d: array<u32, 9>;
    var carry = c;
    for (var k = 8; k >= 0; k--) {
        let n = grid.lens[k / 4][k % 4];
        let s = grid.first[k / 4][k % 4] + carry;
        d[k] = s % n;
        carry = s / n;
    }
    // R = (Rz Ry Rx)^T from the cosines and sines of yaw, pitch, roll.
    let cx = entry(6u, d[6], 1u);
    let sx = entry(6u, d[6], 2u);
    let cy = entry(7u, d[7], 1u);
    let sy = entry(7u, d[7], 2u);
    let cz = entry(8u, d[8], 1u);
    let sz = entry(8u, d[8], 2u);
    // A = Rz Ry (row-major)
    let a00 = r_mul(cz, cy);
    let a01 = r_neg(sz);
    let a02 = r_mul(cz, sy);
    let a10 = r_mul(sz, cy);
    let a11 = cz;
    let a12 = r_mul(sz, sy);
    let a20 = r_neg(sy);
    let a22 = cy;
    // R's rows are the columns of A Rx.
    var rot = array<Real, 9>(
        a00, a10, a20,
        r_add(r_mul(a01, cx), r_mul(a02, sx)),
        r_add(r_mul(a11, cx), r_mul(a12, sx)),
        r_mul(a22, sx),
        r_sub(r_mul(a02, cx), r_mul(a01, sx)),
        r_sub(r_mul(a12, cx), r_mul(a11, sx)),
        r_mul(a22, cx),
    );
    // t: the placement p2 - R p1, or the translation's values.
    var t: array<Real, 3>;
    if grid.placement == 1u {
        let p1 = spherical(0u, 1u, 2u, d);
        let p2 = spherical(3u, 4u, 5u, d);
        for (var i = 0; i < 3; i++) {
            let rp = r_add(r_add(r_mul(rot[3 * i], p1[0]), r_mul(rot[3 * i + 1], p1[1])), r_mul(rot[3 * i + 2], p1[2]));
            t[i] = r_sub(p2[i], rp);
        }
    } else {
        t = array<Real, 3>(entry(3u, d[3], 0u), entry(4u, d[4], 0u), entry(5u, d[5], 0u));
    }
    // M = range R Rz(base): the arc's base azimuth is the feature's (FLS) or 0 (sidescan).
    let range = entry(0u, d[0], 0u);
    var cb = real(vec2<f32>(1.0, 0.0));
    var sb = real(vec2<f32>(0.0, 0.0));
    if grid.fls == 1u {
        cb = entry(1u, d[1], 1u);
        sb = entry(1u, d[1], 2u);
    }
    var hi: array<vec4<f32>, 3>;
    var lo: array<vec4<f32>, 3>;
    for (var i = 0; i < 3; i++) {
        let m0 = r_mul(r_add(r_mul(rot[3 * i], cb), r_mul(rot[3 * i + 1], sb)), range);
        let m1 = r_mul(r_sub(r_mul(rot[3 * i + 1], cb), r_mul(rot[3 * i], sb)), range);
        let m2 = r_mul(rot[3 * i + 2], range);
        let p = array<vec2<f32>, 4>(r_pair(m0), r_pair(m1), r_pair(m2), r_pair(t[i]));
        hi[i] = vec4<f32>(p[0].x, p[1].x, p[2].x, p[3].x);
        lo[i] = vec4<f32>(p[0].y, p[1].y, p[2].y, p[3].y);
    }
    poses[c] = Pose(hi[0], hi[1], hi[2], lo[0], lo[1], lo[2], plans[d[0]]);
}
