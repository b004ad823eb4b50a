//! Boundary conditions and loads usable from code: prescribed motion of node sets, external
//! forces, body force, initial velocity. Case files (a later crate) build these.

use crate::error::{Error, Result};
use crate::math::{Real, Vector};

/// A scalar function of time.
#[derive(Clone, Debug, PartialEq)]
pub enum TimeFunction {
    /// `c` at all times.
    Constant(Real),
    /// `from` until `t0`, linear to `to` at `t1`, then `to`.
    Ramp {
        t0: Real,
        t1: Real,
        from: Real,
        to: Real,
    },
    /// `from` until `t0`, then a half-cosine to `to` at `t1` (zero slope at both ends: loading
    /// without a shock), then `to`.
    SmoothRamp {
        t0: Real,
        t1: Real,
        from: Real,
        to: Real,
    },
    /// Piecewise linear through `(t, value)` points with increasing t; constant outside.
    Table(Vec<(Real, Real)>),
}

impl TimeFunction {
    /// Check the function is well formed.
    pub fn validate(&self) -> Result<()> {
        let bad = |why: String| {
            Err(Error::InvalidInput {
                what: "time function",
                why,
            })
        };
        match self {
            TimeFunction::Constant(c) if !c.is_finite() => {
                bad(format!("constant {c} is not finite"))
            }
            TimeFunction::Ramp { t0, t1, from, to }
            | TimeFunction::SmoothRamp { t0, t1, from, to } => {
                if ![*t0, *t1, *from, *to].iter().all(|v| v.is_finite()) || t1 <= t0 {
                    bad(format!(
                        "ramp needs finite values and t1 > t0 (got t0 = {t0}, t1 = {t1})"
                    ))
                } else {
                    Ok(())
                }
            }
            TimeFunction::Table(p) => {
                if p.is_empty() {
                    bad("table is empty: give at least one (t, value) point".into())
                } else if p.windows(2).any(|w| !(w[1].0 > w[0].0))
                    || p.iter().any(|(t, v)| !t.is_finite() || !v.is_finite())
                {
                    bad("table times must be finite and strictly increasing".into())
                } else {
                    Ok(())
                }
            }
            _ => Ok(()),
        }
    }

    /// Value at time `t`.
    pub fn value(&self, t: Real) -> Real {
        match self {
            TimeFunction::Constant(c) => *c,
            TimeFunction::Ramp { t0, t1, from, to } => {
                if t <= *t0 {
                    *from
                } else if t >= *t1 {
                    *to
                } else {
                    from + (to - from) * (t - t0) / (t1 - t0)
                }
            }
            TimeFunction::SmoothRamp { t0, t1, from, to } => {
                if t <= *t0 {
                    *from
                } else if t >= *t1 {
                    *to
                } else {
                    let s = (t - t0) / (t1 - t0);
                    from + (to - from) * 0.5 * (1.0 - (std::f64::consts::PI * s).cos())
                }
            }
            TimeFunction::Table(p) => {
                if t <= p[0].0 {
                    return p[0].1;
                }
                for w in p.windows(2) {
                    if t <= w[1].0 {
                        return w[0].1 + (w[1].1 - w[0].1) * (t - w[0].0) / (w[1].0 - w[0].0);
                    }
                }
                p[p.len() - 1].1
            }
        }
    }
}

/// How prescribed DOFs move.
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    /// Held at their reference position, at rest.
    Fixed,
    /// Velocity `v(t)` (m/s); the displacement follows by the same leapfrog update as free nodes.
    Velocity(TimeFunction),
    /// Displacement `u(t)` (m) from the reference position; the velocity is its difference quotient
    /// over the step.
    Displacement(TimeFunction),
}

/// A set of nodes whose motion along one axis is prescribed.
#[derive(Clone, Debug, PartialEq)]
pub struct Prescribed {
    pub nodes: Vec<u32>,
    /// 0, 1 or 2 (x, y, z).
    pub axis: usize,
    pub motion: Motion,
}

/// A force applied to each node of a set: `force * scale(t)` per node (N).
#[derive(Clone, Debug, PartialEq)]
pub struct Load {
    pub nodes: Vec<u32>,
    pub force: Vector,
    pub scale: TimeFunction,
}

/// All boundary conditions and loads of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Loading {
    pub prescribed: Vec<Prescribed>,
    pub loads: Vec<Load>,
    /// Body force per unit mass (m/s^2), e.g. gravity.
    pub body_acceleration: Vector,
}

impl Loading {
    /// Check node indices and functions against a body of `n` nodes.
    pub fn validate(&self, n: usize) -> Result<()> {
        for p in &self.prescribed {
            if p.axis > 2 {
                return Err(Error::InvalidInput {
                    what: "prescribed motion",
                    why: format!("axis {} (use 0, 1 or 2)", p.axis),
                });
            }
            check_nodes(&p.nodes, n)?;
            match &p.motion {
                Motion::Velocity(f) | Motion::Displacement(f) => f.validate()?,
                Motion::Fixed => {}
            }
        }
        for l in &self.loads {
            check_nodes(&l.nodes, n)?;
            l.scale.validate()?;
            if !l.force.iter().all(|v| v.is_finite()) {
                return Err(Error::InvalidInput {
                    what: "load",
                    why: "force is not finite".into(),
                });
            }
        }
        if !self.body_acceleration.iter().all(|v| v.is_finite()) {
            return Err(Error::InvalidInput {
                what: "body force",
                why: "acceleration is not finite".into(),
            });
        }
        Ok(())
    }
}

fn check_nodes(nodes: &[u32], n: usize) -> Result<()> {
    if let Some(&bad) = nodes.iter().find(|&&i| i as usize >= n) {
        return Err(Error::InvalidInput {
            what: "node set",
            why: format!("node {bad} does not exist (the body has {n} nodes)"),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_functions_interpolate() {
        let r = TimeFunction::Ramp {
            t0: 1.0,
            t1: 3.0,
            from: 0.0,
            to: 4.0,
        };
        assert_eq!((r.value(0.0), r.value(2.0), r.value(9.0)), (0.0, 2.0, 4.0));
        let t = TimeFunction::Table(vec![(0.0, 1.0), (1.0, 3.0), (2.0, -1.0)]);
        assert_eq!(
            (t.value(-1.0), t.value(0.5), t.value(1.5), t.value(5.0)),
            (1.0, 2.0, 1.0, -1.0)
        );
        assert!(TimeFunction::Table(vec![(1.0, 0.0), (1.0, 2.0)])
            .validate()
            .is_err());
        assert!(TimeFunction::Ramp {
            t0: 1.0,
            t1: 1.0,
            from: 0.0,
            to: 1.0
        }
        .validate()
        .is_err());
    }
}
