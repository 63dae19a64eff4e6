//! The binary scalar types particle files store (PLY, VTK, VTK XML name them each their
//! own way), read as f64.

/// One stored scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    /// Bytes per value.
    pub(crate) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    /// The value at the start of `b` (at least [`Scalar::size`] bytes), in either byte
    /// order; 64-bit integers rounded to the nearest f64 (exact to 2⁵³).
    #[inline]
    pub(crate) fn read(self, b: &[u8], big_endian: bool) -> f64 {
        macro_rules! num {
            ($t:ty) => {{
                const N: usize = std::mem::size_of::<$t>();
                let bytes: [u8; N] = b[..N].try_into().expect("sized by the type");
                (if big_endian {
                    <$t>::from_be_bytes(bytes)
                } else {
                    <$t>::from_le_bytes(bytes)
                }) as f64
            }};
        }
        match self {
            Scalar::I8 => num!(i8),
            Scalar::U8 => num!(u8),
            Scalar::I16 => num!(i16),
            Scalar::U16 => num!(u16),
            Scalar::I32 => num!(i32),
            Scalar::U32 => num!(u32),
            Scalar::I64 => num!(i64),
            Scalar::U64 => num!(u64),
            Scalar::F32 => num!(f32),
            Scalar::F64 => num!(f64),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_byte_orders_of_every_type() {
        let cases: [(Scalar, Vec<u8>, f64); 5] = [
            (Scalar::I8, vec![0xff], -1.0),
            (Scalar::U16, vec![0x01, 0x02], 258.0),
            (Scalar::I32, (-7i32).to_be_bytes().to_vec(), -7.0),
            (Scalar::F32, 1.5f32.to_be_bytes().to_vec(), 1.5),
            (Scalar::F64, (-0.25f64).to_be_bytes().to_vec(), -0.25),
        ];
        for (kind, big, value) in cases {
            assert_eq!(kind.size(), big.len());
            assert_eq!(kind.read(&big, true), value, "{kind:?}");
            let little: Vec<u8> = big.iter().rev().copied().collect();
            assert_eq!(kind.read(&little, false), value, "{kind:?}");
        }
    }
}
