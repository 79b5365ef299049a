//! The interaction force of paper 002, Eq. 5: concentric zones of repulsion, alignment and
//! attraction around each insect.
//!
//! F_int = Σ_k χ_k / N_k Σ_{j ∈ zone k} [g(r_ji) r̂_ji + (1 − |g(r_ji)|) v̂_ji], with
//! g = −1 in the repulsion zone (r < r_rep), 0 in the alignment zone (r_rep ≤ r < r_ali)
//! and +1 in the attraction zone (r_ali ≤ r ≤ r_att). r̂_ji = (r_j − r_i)/r_ji points from
//! the insect to its neighbour; v̂_ji = (v_j − v_i)/|v_j − v_i| is the direction of the
//! velocity *difference* (not the neighbour's heading), so alignment accelerates an insect
//! towards its neighbours' velocities. Each zone's sum is averaged over the N_k neighbours
//! in it, so each term has magnitude at most χ_k (m/s²).

use glam::Vec3;

/// Zone radii, m: r_rep ≤ r_ali ≤ r_att.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Zones {
    pub r_rep: f32,
    pub r_ali: f32,
    pub r_att: f32,
}

impl Zones {
    /// From Table 1's incremental radii: r_ali = r_rep + r_ali*, r_att = r_ali + r_att*.
    pub fn from_increments(r_rep: f32, r_ali_star: f32, r_att_star: f32) -> Self {
        let r_ali = r_rep + r_ali_star;
        Zones {
            r_rep,
            r_ali,
            r_att: r_ali + r_att_star,
        }
    }

    /// g(x) of Eq. 5: −1 (repulsion), 0 (alignment), +1 (attraction); `None` beyond r_att.
    #[inline]
    pub fn g(&self, x: f32) -> Option<f32> {
        if x < self.r_rep {
            Some(-1.0)
        } else if x < self.r_ali {
            Some(0.0)
        } else if x <= self.r_att {
            Some(1.0)
        } else {
            None
        }
    }
}

/// The three weights χ_rep, χ_ali, χ_att, m/s².
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weights {
    pub rep: f32,
    pub ali: f32,
    pub att: f32,
}

/// Running sums of Eq. 5, one per zone.
#[derive(Clone, Copy, Debug, Default)]
pub struct ZoneSums {
    sum: [Vec3; 3],
    count: [u32; 3],
}

impl ZoneSums {
    /// Adds neighbour j at offset `r_ji` = r_j − r_i (distance `dist`) with velocity
    /// difference `v_ji` = v_j − v_i. Coincident neighbours (no direction) add nothing to
    /// the direction but still count, like the paper's average.
    #[inline]
    pub fn add(&mut self, zones: &Zones, r_ji: Vec3, dist: f32, v_ji: Vec3) {
        let Some(g) = zones.g(dist) else { return };
        let k = (g + 1.0) as usize;
        let r_hat = if dist > 1e-9 { r_ji / dist } else { Vec3::ZERO };
        let vl = v_ji.length();
        let v_hat = if vl > 1e-9 { v_ji / vl } else { Vec3::ZERO };
        self.sum[k] += r_hat * g + v_hat * (1.0 - g.abs());
        self.count[k] += 1;
    }

    /// F_int, m/s².
    pub fn force(&self, w: &Weights) -> Vec3 {
        let chi = [w.rep, w.ali, w.att];
        let mut f = Vec3::ZERO;
        for ((sum, &n), chi) in self.sum.iter().zip(&self.count).zip(chi) {
            if n > 0 {
                f += *sum * (chi / n as f32);
            }
        }
        f
    }

    /// How many neighbours fell in each zone (repulsion, alignment, attraction).
    pub fn counts(&self) -> [u32; 3] {
        self.count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const Z: Zones = Zones {
        r_rep: 1.0,
        r_ali: 2.0,
        r_att: 3.0,
    };
    const W: Weights = Weights {
        rep: 5.0,
        ali: 3.0,
        att: 7.0,
    };

    fn force_from(neighbours: &[(Vec3, Vec3)]) -> Vec3 {
        let mut s = ZoneSums::default();
        for &(r, v) in neighbours {
            s.add(&Z, r, r.length(), v);
        }
        s.force(&W)
    }

    #[test]
    fn each_zone_pushes_aligns_or_pulls_with_its_weight() {
        // Repulsion: away from the neighbour, magnitude χ_rep, whatever the velocities.
        let f = force_from(&[(Vec3::X * 0.5, Vec3::Y)]);
        assert!((f - Vec3::new(-5.0, 0.0, 0.0)).length() < 1e-6, "{f}");
        // Alignment: along the velocity difference, magnitude χ_ali.
        let f = force_from(&[(Vec3::X * 1.5, Vec3::Z * 4.0)]);
        assert!((f - Vec3::Z * 3.0).length() < 1e-6, "{f}");
        // Attraction: towards the neighbour, magnitude χ_att.
        let f = force_from(&[(Vec3::X * 2.5, Vec3::Y)]);
        assert!((f - Vec3::X * 7.0).length() < 1e-6, "{f}");
        // Beyond r_att: nothing.
        assert_eq!(force_from(&[(Vec3::X * 3.5, Vec3::Y)]), Vec3::ZERO);
    }

    #[test]
    fn a_zone_averages_its_neighbours() {
        // Two attractors on opposite sides cancel; a third in the repulsion zone still
        // pushes with the full χ_rep.
        let f = force_from(&[
            (Vec3::X * 2.5, Vec3::ZERO),
            (-Vec3::X * 2.5, Vec3::ZERO),
            (Vec3::Y * 0.5, Vec3::ZERO),
        ]);
        assert!((f - Vec3::new(0.0, -5.0, 0.0)).length() < 1e-6, "{f}");
        let f = force_from(&[(Vec3::X * 2.5, Vec3::ZERO), (Vec3::Z * 2.5, Vec3::ZERO)]);
        assert!((f.length() - 7.0 * 0.5f32.sqrt()).abs() < 1e-5, "{f}");
    }

    #[test]
    fn table_1_radii_are_increments() {
        let z = Zones::from_increments(0.2, 2.2, 9.2);
        assert!((z.r_ali - 2.4).abs() < 1e-6 && (z.r_att - 11.6).abs() < 1e-5);
        assert_eq!(z.g(0.1), Some(-1.0));
        assert_eq!(z.g(2.0), Some(0.0));
        assert_eq!(z.g(11.6), Some(1.0));
        assert_eq!(z.g(11.7), None);
    }
}
