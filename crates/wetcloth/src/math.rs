//! Scalar and vector types, the structure-of-arrays particle store, and row views into it.
//!
//! All physics runs in `f64`. The thesis cloth weighs 8 mg per particle and its springs are
//! 1000 N/m, so gravity stretches a spring by about 80 nm, a few `f32` ulps at 15 cm from the
//! origin: single precision cannot even represent the cloth's sag.

/// The scalar type of the simulation (SI units).
pub type Real = f64;

/// A 3D vector in metres (or the unit its context names), Y up.
pub type Vec3 = glam::DVec3;

/// A number for messages: as Rust writes it (the shortest decimal that reads back to it)
/// where that is short, `0`, or in scientific notation below 1e-4 or from 1e9 on, so that
/// 1e308 reads `1e308` and not as 309 digits.
pub fn num(v: Real) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !v.is_finite() || (1e-4..1e9).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Three numbers for messages, `[x, y, z]`, each as [`num`] writes it.
pub fn num3(v: Vec3) -> String {
    format!("[{}, {}, {}]", num(v.x), num(v.y), num(v.z))
}

/// Particle vectors stored as three arrays (structure of arrays), so the per-row loops of the
/// grid stencil read contiguous lanes and vectorise.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Soa {
    /// x components.
    pub x: Vec<Real>,
    /// y components.
    pub y: Vec<Real>,
    /// z components.
    pub z: Vec<Real>,
}

impl Soa {
    /// `n` zero vectors.
    pub fn zeros(n: usize) -> Self {
        Self {
            x: vec![0.0; n],
            y: vec![0.0; n],
            z: vec![0.0; n],
        }
    }

    /// Number of vectors.
    pub fn len(&self) -> usize {
        self.x.len()
    }

    /// True when there are no vectors.
    pub fn is_empty(&self) -> bool {
        self.x.is_empty()
    }

    /// Vector `i`.
    #[inline]
    pub fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    /// Sets vector `i`.
    #[inline]
    pub fn set(&mut self, i: usize, v: Vec3) {
        self.x[i] = v.x;
        self.y[i] = v.y;
        self.z[i] = v.z;
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        (self.x.capacity() + self.y.capacity() + self.z.capacity()) * std::mem::size_of::<Real>()
    }

    /// Copies the vectors out as an array of `Vec3`.
    pub fn to_vec3(&self) -> Vec<Vec3> {
        (0..self.len()).map(|i| self.get(i)).collect()
    }

    /// Builds the store from an array of `Vec3`.
    pub fn from_vec3(v: &[Vec3]) -> Self {
        Self {
            x: v.iter().map(|p| p.x).collect(),
            y: v.iter().map(|p| p.y).collect(),
            z: v.iter().map(|p| p.z).collect(),
        }
    }
}

/// Mutable x, y, z slices of one row of a vector field (a run of particles along x).
pub(crate) struct RowMut<'a> {
    pub x: &'a mut [Real],
    pub y: &'a mut [Real],
    pub z: &'a mut [Real],
}

impl RowMut<'_> {
    /// The same slices, read-only.
    pub fn as_ref(&self) -> RowRef<'_> {
        RowRef {
            x: self.x,
            y: self.y,
            z: self.z,
        }
    }
}

/// Read-only x, y, z slices of one row of a vector field.
#[derive(Clone, Copy)]
pub(crate) struct RowRef<'a> {
    pub x: &'a [Real],
    pub y: &'a [Real],
    pub z: &'a [Real],
}

impl<'a> RowRef<'a> {
    /// The sub-row `start..start + len`.
    #[inline]
    pub fn slice(self, start: usize, len: usize) -> RowRef<'a> {
        RowRef {
            x: &self.x[start..start + len],
            y: &self.y[start..start + len],
            z: &self.z[start..start + len],
        }
    }

    /// Vector `i` of the row.
    #[inline]
    pub fn get(self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }
}

/// Row `r` (particles `r * nx .. (r + 1) * nx`) of `p` as read-only slices.
#[inline]
pub(crate) fn row(p: &Soa, nx: usize, r: usize) -> RowRef<'_> {
    RowRef {
        x: &p.x[r * nx..(r + 1) * nx],
        y: &p.y[r * nx..(r + 1) * nx],
        z: &p.z[r * nx..(r + 1) * nx],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Huge and tiny values read in scientific notation, everyday ones as written.
    #[test]
    fn messages_print_huge_values_in_scientific_notation() {
        assert_eq!(num(1e308), "1e308");
        assert_eq!(num(-1.5e300), "-1.5e300");
        assert_eq!(num(2.5e-7), "2.5e-7");
        assert_eq!(num(0.01), "0.01");
        assert_eq!(num(10000.0), "10000");
        assert_eq!(num(-0.0), "0");
        assert_eq!(num(Real::INFINITY), "inf");
        assert_eq!(num3(Vec3::new(1e200, 1.0, 0.0)), "[1e200, 1, 0]");
    }
}
