//! The failure-criterion trait and what a criterion sees of one spring.

use hooke_core::Real;

/// The state of one intact spring, as a criterion sees it.
#[derive(Clone, Copy, Debug)]
pub struct SpringState {
    /// Stiffness k (N/m).
    pub k: Real,
    /// Rest length L (m).
    pub rest: Real,
    /// Dispersion lever (m): the rest length for an isotropic material,
    /// [`hooke_core::Body::levers`] for a direction-weighted one.
    pub lever: Real,
    /// Unit direction of the spring in the reference configuration (either sense), for
    /// criteria whose strength depends on it ([`crate::FibreStretch`]).
    pub dir: [Real; 3],
    /// Extension dL = l - L (m).
    pub dl: Real,
    /// Pool ratios p of its two end nodes (from the last force evaluation).
    pub pool: [Real; 2],
    /// Dispersion ratio q of the material.
    pub q: Real,
    /// The spring's strength factor `f_s` (1 unless the spring's material, interface or a
    /// random draw makes it stronger or weaker: [`crate::Fracture::with_strength`]). It scales
    /// the stretches at which the criterion acts: a spring of factor `f_s` fails where one of
    /// factor 1 would at the stretch `dL / (f_s L)` (its critical stretch, or its softening
    /// law's peak and final stretches, are `f_s` times the criterion's; its critical energy
    /// `f_s^2` times).
    pub strength: Real,
}

/// The unit reference direction of the spring from node `i` to node `j`.
pub fn reference_direction(body: &hooke_core::Body, i: usize, j: usize) -> [Real; 3] {
    let d = body.lattice.reference_vector(i, j);
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    [d[0] / l, d[1] / l, d[2] / l]
}

impl SpringState {
    /// Stretch dL / L.
    pub fn stretch(&self) -> Real {
        self.dl / self.rest
    }

    /// Tension T = k dL + q k L (p_i + p_j) (N).
    pub fn tension(&self) -> Real {
        hooke_core::law::tension(
            self.k,
            self.lever,
            self.dl,
            self.q,
            self.pool[0],
            self.pool[1],
        )
    }

    /// Energy the spring carries (J): its direct energy plus its share of both end nodes'
    /// dispersive energy, `w = 1/2 k dL^2 + q/2 k L dL (p_i + p_j)`. Node n's dispersive energy
    /// `q/2 Pi_n^2/S_n = q/2 p_n sum_t k_t L_t dL_t` is split over its springs in proportion to
    /// their terms of the pool, so the shares of all springs add up to U exactly. Under a
    /// uniform stretch s every spring carries `1/2 k s^2 L^2 (1 + 2q)`.
    pub fn energy(&self) -> Real {
        0.5 * self.k * self.dl * self.dl
            + 0.5 * self.q * self.k * self.lever * self.dl * (self.pool[0] + self.pool[1])
    }
}

/// Decides whether an intact spring breaks. Stateless and `Sync`: criteria run in parallel over
/// springs, and the decisions are committed after the pass.
pub trait Criterion: Send + Sync + std::fmt::Debug {
    /// Name used in reports and case files.
    fn name(&self) -> &'static str;
    /// True if the spring fails in this state.
    fn breaks(&self, s: &SpringState) -> bool;
    /// A screen stretch s, if the criterion allows one: `breaks` is then true only when
    /// `dL > s L`, and depends on the spring's own k, L and dL alone (not on the pools). With a
    /// screen, the check is folded into the step's first sweep ([`crate::Fracture::step`]), which
    /// computes each extension anyway; without one, every spring is checked after the step.
    fn screen(&self) -> Option<Real> {
        None
    }
    /// The softening law, if this criterion is one (for reports).
    fn as_softening(&self) -> Option<&crate::Softening> {
        None
    }
    /// True for the spring-energy criterion, whose G_c calibration covers a range of its own
    /// (`crate::energy::energy_calibrated`; for reports).
    fn is_energy(&self) -> bool {
        false
    }
    /// The spring's damage weight after this state, given its weight `w` so far (1 undamaged):
    /// at most `w` (damage is irreversible), 0 to break it. Brittle criteria break or leave
    /// it; a softening law ([`crate::Softening`]) lowers it gradually. The screen, if any,
    /// must still hold: below it the weight stays `w`.
    fn weight(&self, s: &SpringState, w: Real) -> Real {
        if self.breaks(s) {
            0.0
        } else {
            w
        }
    }
}
