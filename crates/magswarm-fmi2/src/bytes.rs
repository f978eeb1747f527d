//! Little helpers for writing a model's state as bytes and reading it back.
//!
//! FMU-state serialization must replay bit-identically, so floats go out as their IEEE
//! bits (little-endian), never through text. Reading is bounds-checked and returns
//! [`Fmi2Err`] on truncated or malformed input, so garbage handed to
//! `fmi2DeSerializeFMUstate` is an error, not a crash.

use crate::model::Fmi2Err;

/// Appending primitive values to a byte buffer.
pub trait PutBytes {
    /// One byte.
    fn put_u8(&mut self, v: u8);
    /// `u32`, little-endian.
    fn put_u32(&mut self, v: u32);
    /// `u64`, little-endian.
    fn put_u64(&mut self, v: u64);
    /// `i32`, little-endian.
    fn put_i32(&mut self, v: i32);
    /// `f64` as its IEEE-754 bits, little-endian (exact, NaN payloads included).
    fn put_f64(&mut self, v: f64);
    /// `bool` as one byte 0/1.
    fn put_bool(&mut self, v: bool);
    /// Length-prefixed (u64) bytes.
    fn put_bytes(&mut self, v: &[u8]);
    /// Length-prefixed UTF-8 text.
    fn put_str(&mut self, v: &str);
}

impl PutBytes for Vec<u8> {
    fn put_u8(&mut self, v: u8) {
        self.push(v);
    }
    fn put_u32(&mut self, v: u32) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn put_u64(&mut self, v: u64) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn put_i32(&mut self, v: i32) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn put_f64(&mut self, v: f64) {
        self.extend_from_slice(&v.to_bits().to_le_bytes());
    }
    fn put_bool(&mut self, v: bool) {
        self.push(v as u8);
    }
    fn put_bytes(&mut self, v: &[u8]) {
        self.put_u64(v.len() as u64);
        self.extend_from_slice(v);
    }
    fn put_str(&mut self, v: &str) {
        self.put_bytes(v.as_bytes());
    }
}

/// A bounds-checked cursor over serialized bytes.
pub struct ByteReader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> ByteReader<'a> {
    /// Start reading `buf` at its beginning.
    pub fn new(buf: &'a [u8]) -> Self {
        ByteReader { buf, pos: 0 }
    }

    /// Bytes not read yet.
    pub fn remaining(&self) -> usize {
        self.buf.len() - self.pos
    }

    /// The next `n` bytes.
    pub fn take(&mut self, n: usize) -> Result<&'a [u8], Fmi2Err> {
        if n > self.remaining() {
            return Err(Fmi2Err::error(format!(
                "serialized state is truncated: needed {n} more bytes at offset {} but only {} remain",
                self.pos,
                self.remaining()
            )));
        }
        let s = &self.buf[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], Fmi2Err> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }

    /// One byte.
    pub fn u8(&mut self) -> Result<u8, Fmi2Err> {
        Ok(self.array::<1>()?[0])
    }
    /// `u32`.
    pub fn u32(&mut self) -> Result<u32, Fmi2Err> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    /// `u64`.
    pub fn u64(&mut self) -> Result<u64, Fmi2Err> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    /// `i32`.
    pub fn i32(&mut self) -> Result<i32, Fmi2Err> {
        Ok(i32::from_le_bytes(self.array()?))
    }
    /// `f64` from its bits.
    pub fn f64(&mut self) -> Result<f64, Fmi2Err> {
        Ok(f64::from_bits(self.u64()?))
    }
    /// `bool` (a byte that must be 0 or 1).
    pub fn bool(&mut self) -> Result<bool, Fmi2Err> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            b => Err(Fmi2Err::error(format!(
                "serialized state: invalid boolean byte {b}"
            ))),
        }
    }
    /// Length-prefixed bytes.
    pub fn bytes(&mut self) -> Result<&'a [u8], Fmi2Err> {
        let n = self.u64()?;
        let n =
            usize::try_from(n).map_err(|_| Fmi2Err::error("serialized state: length overflows"))?;
        self.take(n)
    }
    /// Length-prefixed UTF-8 text.
    pub fn str(&mut self) -> Result<&'a str, Fmi2Err> {
        std::str::from_utf8(self.bytes()?)
            .map_err(|_| Fmi2Err::error("serialized state: text is not UTF-8"))
    }
    /// Err unless every byte was consumed (catches states of another layout).
    pub fn finish(&self) -> Result<(), Fmi2Err> {
        if self.remaining() == 0 {
            Ok(())
        } else {
            Err(Fmi2Err::error(format!(
                "serialized state has {} unexpected trailing bytes",
                self.remaining()
            )))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_truncation() {
        let mut v = Vec::new();
        v.put_f64(-0.0);
        v.put_f64(f64::from_bits(0x7ff8_0000_0000_1234));
        v.put_str("héllo");
        v.put_bool(true);
        v.put_i32(-7);
        let mut r = ByteReader::new(&v);
        assert_eq!(r.f64().unwrap().to_bits(), (-0.0f64).to_bits());
        assert_eq!(r.f64().unwrap().to_bits(), 0x7ff8_0000_0000_1234);
        assert_eq!(r.str().unwrap(), "héllo");
        assert!(r.bool().unwrap());
        assert_eq!(r.i32().unwrap(), -7);
        r.finish().unwrap();
        let mut r = ByteReader::new(&v[..5]);
        assert!(r.f64().is_err());
        let mut bad = Vec::new();
        bad.put_u64(u64::MAX);
        assert!(ByteReader::new(&bad).bytes().is_err());
    }
}
