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

/// Node coordinates (or velocities, forces) as three component arrays (structure of arrays), so
/// the hot loops read contiguous memory per component.
///
/// The three components live one after the other in a single buffer of `3 n` values: x, then y,
/// then z. A reader outside Rust (numpy) can therefore see the whole field as one `n x 3` array
/// with strides `(8, 8 n)` bytes, without a copy. The buffer is never reallocated after
/// construction: `clone_from` and `copy_from` reuse it, so a view handed out stays valid as long
/// as the owner lives.
#[derive(Debug, Default, PartialEq)]
pub struct Coords {
    data: Vec<Real>,
    n: usize,
}

impl Clone for Coords {
    fn clone(&self) -> Self {
        Coords {
            data: self.data.clone(),
            n: self.n,
        }
    }

    /// Reuses this buffer when the lengths agree (no reallocation).
    fn clone_from(&mut self, source: &Self) {
        self.data.clone_from(&source.data);
        self.n = source.n;
    }
}

impl Coords {
    /// Heap bytes held (see [`crate::memory::Footprint`]).
    pub fn heap_bytes(&self) -> usize {
        crate::memory::bytes(&self.data)
    }

    /// `n` nodes, all zero.
    pub fn zeros(n: usize) -> Self {
        Coords {
            data: vec![0.0; 3 * n],
            n,
        }
    }

    /// From three component arrays of equal length.
    pub fn from_components(x: &[Real], y: &[Real], z: &[Real]) -> Self {
        assert!(
            x.len() == y.len() && y.len() == z.len(),
            "components differ in length"
        );
        let mut data = Vec::with_capacity(3 * x.len());
        data.extend_from_slice(x);
        data.extend_from_slice(y);
        data.extend_from_slice(z);
        Coords { data, n: x.len() }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.n
    }

    /// True when there is no node.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The x components.
    #[inline]
    pub fn x(&self) -> &[Real] {
        &self.data[..self.n]
    }

    /// The y components.
    #[inline]
    pub fn y(&self) -> &[Real] {
        &self.data[self.n..2 * self.n]
    }

    /// The z components.
    #[inline]
    pub fn z(&self) -> &[Real] {
        &self.data[2 * self.n..]
    }

    /// The x components, writable.
    #[inline]
    pub fn x_mut(&mut self) -> &mut [Real] {
        let n = self.n;
        &mut self.data[..n]
    }

    /// The y components, writable.
    #[inline]
    pub fn y_mut(&mut self) -> &mut [Real] {
        let n = self.n;
        &mut self.data[n..2 * n]
    }

    /// The z components, writable.
    #[inline]
    pub fn z_mut(&mut self) -> &mut [Real] {
        let n = self.n;
        &mut self.data[2 * n..]
    }

    /// The three components, writable at once.
    #[inline]
    pub fn xyz_mut(&mut self) -> [&mut [Real]; 3] {
        let n = self.n;
        let (x, yz) = self.data.split_at_mut(n);
        let (y, z) = yz.split_at_mut(n);
        [x, y, z]
    }

    /// The whole buffer: x, then y, then z (`3 n` values).
    #[inline]
    pub fn as_flat(&self) -> &[Real] {
        &self.data
    }

    /// Overwrite with `o` (same node count), in place.
    pub fn copy_from(&mut self, o: &Coords) {
        self.data.copy_from_slice(&o.data);
    }

    /// Node `i` as a vector.
    #[inline]
    pub fn get(&self, i: usize) -> Vector {
        let n = self.n;
        Vector::new(self.data[i], self.data[n + i], self.data[2 * n + i])
    }

    /// Overwrite node `i`.
    #[inline]
    pub fn set(&mut self, i: usize, v: Vector) {
        let n = self.n;
        self.data[i] = v.x;
        self.data[n + i] = v.y;
        self.data[2 * n + i] = v.z;
    }

    /// Component `c` (0, 1, 2) of node `i`.
    #[inline]
    pub fn comp(&self, c: usize) -> &[Real] {
        let n = self.n;
        &self.data[c.min(2) * n..(c.min(2) + 1) * n]
    }

    /// Mutable component `c` (0, 1, 2).
    #[inline]
    pub fn comp_mut(&mut self, c: usize) -> &mut [Real] {
        let n = self.n;
        &mut self.data[c.min(2) * n..(c.min(2) + 1) * n]
    }

    /// Set every entry to zero without reallocating.
    pub fn fill_zero(&mut self) {
        self.data.fill(0.0);
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
