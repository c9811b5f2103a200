//! Little-endian values read in order from bytes whose length the caller checked (the
//! headers of the project's binary files: the vocabulary, the map file).

/// A cursor over `bytes`: each read takes the next values. Reading past the end is a
/// bug of the caller's length check, so it panics like a slice index.
pub struct LeReader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> LeReader<'a> {
    /// A cursor at `at` in `bytes`.
    pub fn new(bytes: &'a [u8], at: usize) -> Self {
        Self { bytes, at }
    }

    /// Bytes read so far (the offset of the next read).
    pub fn position(&self) -> usize {
        self.at
    }

    /// The next `len` bytes.
    pub fn slice(&mut self, len: usize) -> &'a [u8] {
        let out = &self.bytes[self.at..self.at + len];
        self.at += len;
        out
    }

    /// The next `N` bytes.
    pub fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0; N];
        out.copy_from_slice(self.slice(N));
        out
    }

    /// The next `u32`.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }

    /// The next `u64`.
    pub fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }

    /// The next `f64`.
    pub fn f64(&mut self) -> f64 {
        f64::from_le_bytes(self.take())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_read_in_order_little_endian() {
        let mut bytes = vec![];
        bytes.extend_from_slice(&7u32.to_le_bytes());
        bytes.extend_from_slice(&(1u64 << 40).to_le_bytes());
        bytes.extend_from_slice(&2.5f64.to_le_bytes());
        bytes.extend_from_slice(b"ab");
        let mut r = LeReader::new(&bytes, 0);
        assert_eq!(r.u32(), 7);
        assert_eq!(r.u64(), 1 << 40);
        assert_eq!(r.f64(), 2.5);
        assert_eq!(r.position(), 20);
        assert_eq!(r.slice(2), b"ab");
    }
}
