//! Little-endian byte encoding for [`crate::export::Model::save_state`] and `restore_state`.
//!
//! f64 values are stored bit for bit, so a restored state reproduces every output exactly.

/// Appends values to a state buffer.
pub struct StateWriter<'a> {
    out: &'a mut Vec<u8>,
}

impl<'a> StateWriter<'a> {
    pub fn new(out: &'a mut Vec<u8>) -> StateWriter<'a> {
        StateWriter { out }
    }
    pub fn f64(&mut self, x: f64) -> &mut Self {
        self.out.extend_from_slice(&x.to_bits().to_le_bytes());
        self
    }
    pub fn f64s(&mut self, xs: &[f64]) -> &mut Self {
        self.u64(xs.len() as u64);
        self.out.reserve(8 * xs.len());
        for &x in xs {
            self.out.extend_from_slice(&x.to_bits().to_le_bytes());
        }
        self
    }
    pub fn u64(&mut self, x: u64) -> &mut Self {
        self.out.extend_from_slice(&x.to_le_bytes());
        self
    }
    pub fn i32(&mut self, x: i32) -> &mut Self {
        self.out.extend_from_slice(&x.to_le_bytes());
        self
    }
    pub fn u8(&mut self, x: u8) -> &mut Self {
        self.out.push(x);
        self
    }
    pub fn bool(&mut self, b: bool) -> &mut Self {
        self.out.push(b as u8);
        self
    }
    pub fn str(&mut self, s: &str) -> &mut Self {
        self.u64(s.len() as u64);
        self.out.extend_from_slice(s.as_bytes());
        self
    }
}

/// Reads values back in the order they were written; every read checks the length.
pub struct StateReader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> StateReader<'a> {
    pub fn new(bytes: &'a [u8]) -> StateReader<'a> {
        StateReader { bytes, pos: 0 }
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| {
            format!("state truncated: need {n} bytes at offset {}, have {}", self.pos, self.bytes.len())
        })?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    pub fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_bits(self.u64()?))
    }
    /// Reads a slice written by [`StateWriter::f64s`] into `out`, which must have its length.
    pub fn f64s_into(&mut self, out: &mut [f64]) -> Result<(), String> {
        let n = self.u64()?;
        if n != out.len() as u64 {
            return Err(format!("state holds {n} values where {} are expected", out.len()));
        }
        self.fill(out)
    }
    /// Reads a slice written by [`StateWriter::f64s`] into `out`, resized to its length
    /// (its allocation is reused).
    pub fn f64s_to_vec(&mut self, out: &mut Vec<f64>) -> Result<(), String> {
        let n = usize::try_from(self.u64()?).map_err(|_| "state slice too long".to_owned())?;
        if n > (self.bytes.len() - self.pos) / 8 {
            return Err(format!("state truncated: {n} values announced, {} bytes left", self.bytes.len() - self.pos));
        }
        out.resize(n, 0.0);
        self.fill(out)
    }
    fn fill(&mut self, out: &mut [f64]) -> Result<(), String> {
        let bytes = self.take(8 * out.len())?;
        for (x, b) in out.iter_mut().zip(bytes.chunks_exact(8)) {
            *x = f64::from_bits(u64::from_le_bytes(b.try_into().expect("8 bytes")));
        }
        Ok(())
    }
    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().expect("8 bytes")))
    }
    pub fn i32(&mut self) -> Result<i32, String> {
        Ok(i32::from_le_bytes(self.take(4)?.try_into().expect("4 bytes")))
    }
    pub fn u8(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }
    pub fn bool(&mut self) -> Result<bool, String> {
        match self.take(1)?[0] {
            0 => Ok(false),
            1 => Ok(true),
            b => Err(format!("state holds {b} where a boolean is expected")),
        }
    }
    pub fn string(&mut self) -> Result<String, String> {
        let n = usize::try_from(self.u64()?).map_err(|_| "state string too long".to_owned())?;
        let b = self.take(n)?;
        String::from_utf8(b.to_vec()).map_err(|_| "state string is not UTF-8".to_owned())
    }
    /// The bytes not read yet.
    pub fn rest(self) -> &'a [u8] {
        &self.bytes[self.pos..]
    }
    /// Every byte must have been read.
    pub fn finish(self) -> Result<(), String> {
        if self.pos == self.bytes.len() {
            Ok(())
        } else {
            Err(format!("state has {} unexpected trailing bytes", self.bytes.len() - self.pos))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_bit_for_bit() {
        let mut buf = Vec::new();
        let vals = [1.0 / 3.0, -0.0, f64::MIN_POSITIVE, 1e300];
        StateWriter::new(&mut buf).f64(f64::NAN).f64s(&vals).u64(7).i32(-3).bool(true).str("scène");
        let mut r = StateReader::new(&buf);
        assert!(r.f64().unwrap().is_nan());
        let mut back = [0.0; 4];
        r.f64s_into(&mut back).unwrap();
        assert_eq!(vals.map(f64::to_bits), back.map(f64::to_bits));
        assert_eq!(r.u64().unwrap(), 7);
        assert_eq!(r.i32().unwrap(), -3);
        assert!(r.bool().unwrap());
        assert_eq!(r.string().unwrap(), "scène");
        r.finish().unwrap();
    }

    #[test]
    fn truncation_and_mismatch_are_errors() {
        let mut buf = Vec::new();
        StateWriter::new(&mut buf).f64s(&[1.0, 2.0]);
        assert!(StateReader::new(&buf[..buf.len() - 1]).f64s_into(&mut [0.0; 2]).unwrap_err().contains("truncated"));
        assert!(StateReader::new(&buf).f64s_into(&mut [0.0; 3]).unwrap_err().contains("2 values"));
        let mut r = StateReader::new(&buf);
        r.u64().unwrap();
        assert!(r.finish().unwrap_err().contains("16 unexpected trailing bytes"));
        assert!(StateReader::new(&[2]).bool().is_err());
    }
}
