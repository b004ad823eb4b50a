//! The one place where the scalar type and the vector types are named.
//!
//! Every body is stored with three coordinates per node. A 2D (plate) model keeps z = 0 exactly:
//! its springs all lie in the plane, so every force has a zero z component and z never moves.
//! This costs a third more memory in 2D but lets one code path serve both dimensions.

/// Scalar type of all physics (SI units).
pub type Real = f64;
/// A 3-vector of `Real`.
pub type Vector = nalgebra::Vector3<Real>;
/// A 3x3 matrix of `Real` (stress, strain).
pub type Matrix = nalgebra::Matrix3<Real>;

/// Node coordinates (or velocities, forces) as three separate arrays (structure of arrays), so
/// the hot loops read contiguous memory per component.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Coords {
    pub x: Vec<Real>,
    pub y: Vec<Real>,
    pub z: Vec<Real>,
}

impl Coords {
    /// `n` nodes, all zero.
    pub fn zeros(n: usize) -> Self {
        Coords {
            x: vec![0.0; n],
            y: vec![0.0; n],
            z: vec![0.0; n],
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when there is no node.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Node `i` as a vector.
    #[inline]
    pub fn get(&self, i: usize) -> Vector {
        Vector::new(self.x[i], self.y[i], self.z[i])
    }

    /// Overwrite node `i`.
    #[inline]
    pub fn set(&mut self, i: usize, v: Vector) {
        self.x[i] = v.x;
        self.y[i] = v.y;
        self.z[i] = v.z;
    }

    /// Component `c` (0, 1, 2) of node `i`.
    #[inline]
    pub fn comp(&self, c: usize) -> &[Real] {
        match c {
            0 => &self.x,
            1 => &self.y,
            _ => &self.z,
        }
    }

    /// Mutable component `c` (0, 1, 2).
    #[inline]
    pub fn comp_mut(&mut self, c: usize) -> &mut [Real] {
        match c {
            0 => &mut self.x,
            1 => &mut self.y,
            _ => &mut self.z,
        }
    }

    /// Set every entry to zero without reallocating.
    pub fn fill_zero(&mut self) {
        self.x.fill(0.0);
        self.y.fill(0.0);
        self.z.fill(0.0);
    }

    /// Euclidean norm over all components (as one long vector).
    pub fn norm(&self) -> Real {
        self.dot(self).sqrt()
    }

    /// Dot product as long vectors.
    pub fn dot(&self, o: &Coords) -> Real {
        let mut s = 0.0;
        for c in 0..3 {
            s += self
                .comp(c)
                .iter()
                .zip(o.comp(c))
                .map(|(a, b)| a * b)
                .sum::<Real>();
        }
        s
    }

    /// `self += a * o`.
    pub fn axpy(&mut self, a: Real, o: &Coords) {
        for c in 0..3 {
            for (s, v) in self.comp_mut(c).iter_mut().zip(o.comp(c)) {
                *s += a * v;
            }
        }
    }
}
