//! Sampling the GGX distribution of visible normals (Heitz 2018, "Sampling the GGX distribution
//! of visible normals", JCGT 7(4), §3 and its Listing 1): map the view direction into the
//! configuration where the surface has roughness 1, sample the projected hemisphere there, and
//! map the normal back. The density of the result is
//! [`visible_normal_density`](crate::physics::visible_normal_density).

use glam::DVec3;

/// A microfacet normal `h` drawn from the visible normals of `wi` (which must have `wi.z >= 0`)
/// for a GGX surface of roughness `alpha`, from a point `u` of the unit square.
pub fn sample_visible_normal(wi: DVec3, alpha: f64, u: [f64; 2]) -> DVec3 {
    const NORMAL: DVec3 = DVec3::Z;
    // Stretch the view direction into the roughness-1 configuration (Heitz 2018, Listing 1, l. 3).
    let stretched = DVec3::new(alpha * wi.x, alpha * wi.y, wi.z);
    let length = stretched.length();
    // A smooth surface, or a rough one seen exactly edge-on with vanishing roughness, has all its
    // visible normals at n: the distribution is a Dirac there.
    if !(length > 1e-150) {
        return NORMAL;
    }
    let vh = stretched / length;
    // An orthonormal basis around vh (Listing 1, l. 5-7).
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 { DVec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt() } else { DVec3::X };
    let t2 = vh.cross(t1);
    // A point on the unit disk, its second coordinate warped toward the visible half (l. 9-13).
    let r = u[0].sqrt();
    let phi = 2.0 * std::f64::consts::PI * u[1];
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    // Reproject onto the hemisphere and unstretch (l. 15-17).
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    let h = DVec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0));
    let h_length = h.length();
    if !(h_length > 1e-150) { NORMAL } else { h / h_length }
}
