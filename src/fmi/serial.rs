//! The byte format of a serialized FMU state (`fmi2SerializeFMUstate`), the plumbing's part.
//!
//! Layout (all integers little-endian; no pointers, so the bytes can be written to a file and
//! read back by another process):
//!
//! | bytes | what |
//! | --- | --- |
//! | 8 | magic `SCMFMU2\0` |
//! | 4 | layout version ([`SERIAL_VERSION`]) |
//! | 4 + n | GUID of the FMU that wrote it: length, then UTF-8 bytes |
//! | 4 | state-machine state (its bit) |
//! | 8 | last successful time (f64 bits) |
//! | 1 (+ 8) | `stopTime` of `fmi2SetupExperiment`: 0, or 1 and its f64 bits |
//! | 8 + m | the model's own bytes ([`FmiModel::serialize_state`](super::contract::FmiModel::serialize_state)): length, then bytes |
//! | 8 | checksum: 64-bit FNV-1a of everything before it |
//!
//! [`decode`] refuses, with a message saying which: bytes that do not start with the magic, a
//! layout version this code does not read, truncated or over-long bytes, a checksum mismatch
//! (corruption), and a state written by an FMU with another GUID (another scene, or another
//! version of the binary).

/// Magic number that starts a serialized FMU state.
pub const SERIAL_MAGIC: &[u8; 8] = b"SCMFMU2\0";
/// Version of the layout written by [`encode`].
pub const SERIAL_VERSION: u32 = 3;

/// 64-bit FNV-1a hash of `bytes` (offset basis xor `seed`). Hand-written: eight lines, and it
/// must stay byte-for-byte stable across versions of any library, since saved states and GUIDs
/// depend on it. Any change of a single byte changes the hash (each step is a bijection of the
/// running hash), so it detects every one-byte corruption.
pub fn fnv1a(bytes: &[u8], seed: u64) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64 ^ seed;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The plumbing's fields of a saved state.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded<'a> {
    /// State-machine state bit.
    pub machine: u32,
    /// Last successful time (s).
    pub last_successful_time: f64,
    /// `stopTime` of `fmi2SetupExperiment` (s), if one was given.
    pub stop_time: Option<f64>,
    /// The model's bytes.
    pub model: &'a [u8],
}

/// Writes a serialized state.
pub fn encode(
    guid: &str,
    machine: u32,
    last_successful_time: f64,
    stop_time: Option<f64>,
    model: &[u8],
) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(8 + 4 + 4 + guid.len() + 4 + 8 + 9 + 8 + model.len() + 8);
    bytes.extend_from_slice(SERIAL_MAGIC);
    bytes.extend_from_slice(&SERIAL_VERSION.to_le_bytes());
    bytes.extend_from_slice(&(guid.len() as u32).to_le_bytes());
    bytes.extend_from_slice(guid.as_bytes());
    bytes.extend_from_slice(&machine.to_le_bytes());
    bytes.extend_from_slice(&last_successful_time.to_bits().to_le_bytes());
    match stop_time {
        None => bytes.push(0),
        Some(stop) => {
            bytes.push(1);
            bytes.extend_from_slice(&stop.to_bits().to_le_bytes());
        }
    }
    bytes.extend_from_slice(&(model.len() as u64).to_le_bytes());
    bytes.extend_from_slice(model);
    let sum = fnv1a(&bytes, 0);
    bytes.extend_from_slice(&sum.to_le_bytes());
    bytes
}

/// A cursor over bytes that reports truncation instead of panicking.
pub struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// Starts at the beginning of `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, at: 0 }
    }

    /// The next `n` bytes.
    pub fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
        match end {
            Some(end) => {
                let s = &self.bytes[self.at..end];
                self.at = end;
                Ok(s)
            }
            None => Err(format!(
                "serialized state is truncated: {} bytes, {what} needs {n} more after byte {}",
                self.bytes.len(),
                self.at
            )),
        }
    }

    /// A little-endian u32.
    pub fn u32(&mut self, what: &str) -> Result<u32, String> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// A little-endian u64.
    pub fn u64(&mut self, what: &str) -> Result<u64, String> {
        let b = self.take(8, what)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }

    /// A little-endian f64 (from its bits).
    pub fn f64(&mut self, what: &str) -> Result<f64, String> {
        Ok(f64::from_bits(self.u64(what)?))
    }

    /// Bytes consumed so far.
    pub fn position(&self) -> usize {
        self.at
    }

    /// Bytes not consumed yet.
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.at
    }
}

/// Reads a serialized state written by [`encode`] for an FMU with GUID `guid`.
pub fn decode<'a>(bytes: &'a [u8], guid: &str) -> Result<Decoded<'a>, String> {
    if bytes.len() < SERIAL_MAGIC.len() || &bytes[..SERIAL_MAGIC.len()] != SERIAL_MAGIC {
        return Err("the bytes are not a serialized state of an scm FMU (bad magic number)".into());
    }
    let mut r = Reader::new(bytes);
    r.take(SERIAL_MAGIC.len(), "the magic number")?;
    let version = r.u32("the layout version")?;
    if version != SERIAL_VERSION {
        return Err(format!("serialized state has layout version {version}; this FMU reads version {SERIAL_VERSION} only"));
    }
    let guid_len = r.u32("the GUID length")? as usize;
    let stored_guid = r.take(guid_len, "the GUID")?;
    let machine = r.u32("the state-machine state")?;
    let last_successful_time = r.f64("the last successful time")?;
    let stop_time = match r.take(1, "the stop time flag")?[0] {
        0 => None,
        1 => Some(r.f64("the stop time")?),
        f => return Err(format!("serialized state is corrupt: stop time flag {f}")),
    };
    let model_len = r.u64("the model state length")?;
    let model_len = usize::try_from(model_len)
        .map_err(|_| format!("serialized state is corrupt: model state length {model_len}"))?;
    let model = r.take(model_len, "the model state")?;
    let body_end = r.position();
    let sum = r.u64("the checksum")?;
    if r.remaining() != 0 {
        return Err(format!(
            "serialized state is corrupt: {} bytes after the checksum",
            r.remaining()
        ));
    }
    if fnv1a(&bytes[..body_end], 0) != sum {
        return Err("serialized state is corrupt: checksum mismatch".into());
    }
    if stored_guid != guid.as_bytes() {
        return Err(format!(
            "serialized state belongs to another FMU (guid {}); this FMU is {guid}: a state is only valid for the scene and the scm version that wrote it",
            String::from_utf8_lossy(stored_guid)
        ));
    }
    Ok(Decoded {
        machine,
        last_successful_time,
        stop_time,
        model,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const GUID: &str = "{guid-a}";

    #[test]
    fn round_trip() {
        let bytes = encode(GUID, 4, 1.25, Some(-2.5), b"model bytes");
        let d = decode(&bytes, GUID).unwrap();
        assert_eq!(
            d,
            Decoded {
                machine: 4,
                last_successful_time: 1.25,
                stop_time: Some(-2.5),
                model: b"model bytes"
            }
        );
        let bytes = encode(GUID, 4, 1.25, None, b"");
        assert_eq!(
            decode(&bytes, GUID).unwrap(),
            Decoded {
                machine: 4,
                last_successful_time: 1.25,
                stop_time: None,
                model: b""
            }
        );
    }

    #[test]
    fn refuses_foreign_old_corrupt_and_truncated_bytes() {
        let bytes = encode(GUID, 4, 1.25, Some(3.0), b"model bytes");
        let err = decode(&bytes, "{guid-b}").unwrap_err();
        assert!(
            err.contains("another FMU") && err.contains("{guid-a}"),
            "{err}"
        );
        let mut old = bytes.clone();
        old[8] = 1;
        assert!(decode(&old, GUID).unwrap_err().contains("layout version 1"));
        for n in [0, 5, 8, 20, bytes.len() - 1] {
            let err = decode(&bytes[..n], GUID).unwrap_err();
            assert!(
                err.contains("truncated") || err.contains("magic"),
                "{n}: {err}"
            );
        }
        let mut long = bytes.clone();
        long.push(0);
        assert!(decode(&long, GUID)
            .unwrap_err()
            .contains("after the checksum"));
        // Every single-byte corruption after the header fields that are checked first is caught.
        for i in 12..bytes.len() {
            let mut bad = bytes.clone();
            bad[i] ^= 0x40;
            assert!(
                decode(&bad, GUID).is_err(),
                "corruption of byte {i} not detected"
            );
        }
        assert!(decode(b"not a state at all", GUID)
            .unwrap_err()
            .contains("magic"));
    }
}
