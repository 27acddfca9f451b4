//! Saved FMU states: what an `fmi2FMUstate` points to, and its bytes.
//!
//! A state is stored in its serialized form, so get/set and (de)serialize share one mechanism:
//! `FMI2RSv3` (8 bytes: the format and its version), then postcard's encoding of the layer's
//! [`Header`] and of the model's [`Model::State`]. A state written out of the process
//! (`fmi2SerializeFMUstate`) ends with the [digest](crate::digest) of those bytes, checked when it
//! comes back, so a damaged or edited one is refused. postcard writes an f64 as its 8
//! little-endian bytes, so a rollback reproduces every number bit for bit; it refuses truncated
//! input, invalid tags, booleans and UTF-8, and we refuse trailing bytes, so random or foreign
//! bytes are rejected with a message. A model keeps the files it read as their names and digests
//! ([`crate::resources::SavedFile`]): restored only with the same contents.
//! Long vectors of numbers go as one block of bytes ([`Reals`]).

use std::any::Any;
use std::fmt;

use serde::de::{self, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::Model;
use super::instance::{Instance, Msg, Phase};
use crate::ffi::fmi2FMUstate;

/// First bytes of every saved state of this layer (format 3: postcard, a digest when serialized).
const STATE_MAGIC: &[u8; 8] = b"FMI2RSv3";
/// What every format of this layer starts with; the last byte is the version.
const FORMAT_PREFIX: &[u8; 7] = b"FMI2RSv";
/// Bytes of the digest that ends a serialized state.
const DIGEST_BYTES: usize = 8;

/// A state as written out of the process: its bytes and their digest.
pub(crate) fn serialized(bytes: &[u8], out: &mut [u8]) {
    let (body, digest) = out.split_at_mut(bytes.len());
    body.copy_from_slice(bytes);
    digest[..DIGEST_BYTES].copy_from_slice(&crate::digest::digest(bytes).to_le_bytes());
}

/// The size of [`serialized`]'s output.
pub(crate) fn serialized_len(bytes: &[u8]) -> usize {
    bytes.len() + DIGEST_BYTES
}

/// The state in serialized bytes, if their digest matches.
pub(crate) fn from_serialized(data: &[u8]) -> Result<&[u8], String> {
    let Some(split) = data.len().checked_sub(DIGEST_BYTES).filter(|&n| n >= STATE_MAGIC.len()) else {
        return Err(format!("not a state of this FMU: {} bytes are too few", data.len()));
    };
    let (body, digest) = data.split_at(split);
    if !body.starts_with(STATE_MAGIC) && body.starts_with(FORMAT_PREFIX) {
        let version = String::from_utf8_lossy(&body[..STATE_MAGIC.len()]).into_owned();
        return Err(format!("a state of another format (`{version}`); this FMU reads `FMI2RSv3`"));
    }
    if digest != crate::digest::digest(body).to_le_bytes() {
        return Err("not a state of this FMU: its digest does not match its bytes (damaged or edited)".into());
    }
    Ok(body)
}
/// First field of every [`Snapshot`] this layer allocates.
const SNAPSHOT_TAG: u64 = 0x5253_5441_5445_4d49;

/// What an `fmi2FMUstate` of this layer points to: the state's bytes, or the state kept in
/// memory by a model that saves so ([`Model::save_in_memory`]), its bytes made when an importer
/// asks for them (serialization).
pub(crate) struct Snapshot {
    tag: u64,
    pub(crate) bytes: Vec<u8>,
    memory: Option<InMemory>,
}

/// A state kept in memory: the layer's fields and the model's state.
struct InMemory {
    fields: Fields,
    model: Box<dyn Any + Send>,
    /// Whether the snapshot's bytes hold this state too.
    bytes_current: bool,
}

/// The layer's part of a state, as the instance holds it.
#[derive(Clone, Copy)]
struct Fields {
    phase: Phase,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    terminated: bool,
}

impl Snapshot {
    /// A snapshot of these bytes.
    pub(crate) fn of_bytes(bytes: Vec<u8>) -> Snapshot {
        Snapshot { tag: SNAPSHOT_TAG, bytes, memory: None }
    }

    /// The snapshot on the heap, as the importer's opaque `fmi2FMUstate`.
    pub(crate) fn into_raw(self) -> fmi2FMUstate {
        Box::into_raw(Box::new(self)).cast()
    }

    /// Replaces the contents with these bytes.
    pub(crate) fn set_bytes(&mut self, bytes: &[u8]) {
        self.memory = None;
        self.bytes.clear();
        self.bytes.extend_from_slice(bytes);
    }
}

/// The snapshot an `fmi2FMUstate` points to. The tag check is a best effort against an
/// importer's mistakes, not a proof: it refuses a state freed by `fmi2FreeFMUstate` (its tag is
/// cleared) while that memory is still intact. A state of another
/// FMU built with this layer passes it and is refused later by its GUID. A pointer to anything
/// else cannot be detected at all: reading its first eight bytes is already undefined behaviour.
///
/// # Safety
/// `state` is null or was returned by [`Snapshot::into_raw`] and not freed since; nothing else
/// accesses the snapshot while the returned reference lives (FMI 2.0 gives an importer that
/// duty: one call on an instance and its states at a time).
pub(crate) unsafe fn snapshot_mut<'a>(state: fmi2FMUstate) -> Result<&'a mut Snapshot, String> {
    if state.is_null() {
        return Err("`FMUstate` is a null pointer".into());
    }
    // SAFETY: by the contract above, a non-null `state` points to a live `Snapshot` that no one
    // else accesses now.
    let snap = unsafe { &mut *state.cast::<Snapshot>() };
    if snap.tag != SNAPSHOT_TAG {
        return Err("`FMUstate` does not point to a live FMU state of this layer (freed already?)".into());
    }
    Ok(snap)
}

/// Frees a snapshot.
///
/// # Safety
/// As [`snapshot_mut`], and `state` is not used afterwards.
pub(crate) unsafe fn free_snapshot(state: fmi2FMUstate) -> Result<(), String> {
    // SAFETY: the caller's contract is snapshot_mut's.
    unsafe { snapshot_mut(state) }?.tag = 0;
    // SAFETY: `state` came from `Box::into_raw` in `Snapshot::into_raw` (checked as far as a tag
    // can) and is not used again.
    drop(unsafe { Box::from_raw(state.cast::<Snapshot>()) });
    Ok(())
}

/// The layer's part of a saved state.
#[derive(Serialize, Deserialize)]
struct Header<'a> {
    guid: &'a str,
    phase: Phase,
    time: f64,
    start_time: f64,
    stop_time: Option<f64>,
    terminated: bool,
}

/// A postcard output that appends to a buffer, reusing its allocation.
struct Append<'a>(&'a mut Vec<u8>);

impl postcard::ser_flavors::Flavor for Append<'_> {
    type Output = ();
    #[inline]
    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        self.0.extend_from_slice(data);
        Ok(())
    }
    #[inline]
    fn try_push(&mut self, data: u8) -> postcard::Result<()> {
        self.0.push(data);
        Ok(())
    }
    fn finalize(self) -> postcard::Result<()> {
        Ok(())
    }
}

/// Appends postcard's encoding of `value` to `out`.
pub(crate) fn append<T: Serialize>(value: &T, out: &mut Vec<u8>) -> Result<(), String> {
    postcard::serialize_with_flavor(value, Append(out)).map_err(|e| format!("cannot serialize the state: {e}"))
}

/// Decodes `bytes`, every one of them, as a `T`.
pub(crate) fn decode_all<'b, T: Deserialize<'b>>(bytes: &'b [u8]) -> Result<T, String> {
    let not_ours = |e: postcard::Error| format!("not a state of this FMU: {e}");
    let (value, rest) = postcard::take_from_bytes::<T>(bytes).map_err(not_ours)?;
    if !rest.is_empty() {
        return Err(format!("not a state of this FMU: {} unexpected trailing bytes", rest.len()));
    }
    Ok(value)
}

/// A long vector of f64 in a model's saved state, written as its numbers' little-endian bytes
/// in one piece (postcard would frame every number; for the thousands a cable net holds that
/// costs more than the rest of a rollback). Saving borrows the model's numbers; restoring
/// borrows the bytes of the saved state and copies them out with [`Reals::copy_into`].
#[derive(Clone, Copy, Debug)]
pub struct Reals<'a>(RealsInner<'a>);

#[derive(Clone, Copy, Debug)]
enum RealsInner<'a> {
    Numbers(&'a [f64]),
    /// Little-endian, a multiple of 8 bytes long.
    Bytes(&'a [u8]),
}

impl<'a> Reals<'a> {
    /// The numbers to save.
    pub fn new(numbers: &'a [f64]) -> Reals<'a> {
        Reals(RealsInner::Numbers(numbers))
    }

    pub fn len(&self) -> usize {
        match self.0 {
            RealsInner::Numbers(x) => x.len(),
            RealsInner::Bytes(b) => b.len() / 8,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Replaces the contents of `out` with the numbers, bit for bit (its allocation is reused).
    pub fn copy_into(&self, out: &mut Vec<f64>) {
        out.clear();
        match self.0 {
            RealsInner::Numbers(x) => out.extend_from_slice(x),
            RealsInner::Bytes(b) => {
                out.extend(b.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap_or_default())))
            }
        }
    }
}

impl Serialize for Reals<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self.0 {
            #[cfg(target_endian = "little")]
            RealsInner::Numbers(x) => s.serialize_bytes(bytemuck::cast_slice(x)),
            #[cfg(not(target_endian = "little"))]
            RealsInner::Numbers(x) => s.serialize_bytes(&x.iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<u8>>()),
            RealsInner::Bytes(b) => s.serialize_bytes(b),
        }
    }
}

impl<'de: 'a, 'a> Deserialize<'de> for Reals<'a> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Bytes<'a>(std::marker::PhantomData<&'a ()>);
        impl<'de: 'a, 'a> Visitor<'de> for Bytes<'a> {
            type Value = Reals<'a>;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("the little-endian bytes of f64 numbers (a multiple of 8)")
            }
            fn visit_borrowed_bytes<E: de::Error>(self, b: &'de [u8]) -> Result<Reals<'a>, E> {
                if !b.len().is_multiple_of(8) {
                    return Err(E::invalid_length(b.len(), &self));
                }
                Ok(Reals(RealsInner::Bytes(b)))
            }
        }
        d.deserialize_bytes(Bytes(std::marker::PhantomData))
    }
}

/// The layer's fields and the model's state, checked (a state of this FMU, every byte used).
struct Saved<'b, S> {
    header: Header<'b>,
    model: S,
}

impl<M: Model> Instance<M> {
    fn fields(&self) -> Fields {
        Fields {
            phase: self.phase,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
            terminated: self.terminated,
        }
    }

    /// Saves the current state into `snap` (its storage reused): in memory where the model
    /// keeps it so, else as bytes.
    pub(crate) fn save_snapshot(&mut self, snap: &mut Snapshot) -> Result<(), String> {
        let mut slot = snap.memory.take().map(|m| m.model);
        if self.model.save_in_memory(&mut slot).msg()?
            && let Some(model) = slot
        {
            snap.memory = Some(InMemory { fields: self.fields(), model, bytes_current: false });
            snap.bytes.clear();
            return Ok(());
        }
        self.save_into(&mut snap.bytes)
    }

    /// Restores a state saved by [`Instance::save_snapshot`] (or read from bytes).
    pub(crate) fn restore_snapshot(&mut self, snap: &Snapshot) -> Result<(), String> {
        let Some(m) = &snap.memory else {
            return self.restore_from(&snap.bytes);
        };
        self.model.restore_in_memory(&*m.model).msg()?;
        let f = m.fields;
        (self.phase, self.time, self.start_time, self.stop_time, self.terminated) =
            (f.phase, f.time, f.start_time, f.stop_time, f.terminated);
        Ok(())
    }

    /// The bytes of the state in `snap`; a state kept in memory is written out by restoring it
    /// into this instance, saving it, and restoring the instance's own state (bit for bit).
    pub(crate) fn snapshot_bytes<'s>(&mut self, snap: &'s mut Snapshot) -> Result<&'s [u8], String> {
        if snap.memory.as_ref().is_none_or(|m| m.bytes_current) {
            return Ok(&snap.bytes);
        }
        if matches!(self.phase, Phase::Error | Phase::Fatal) {
            return Err(format!(
                "a state kept in memory is written out through its instance, which is in state `{}` now",
                self.phase.name()
            ));
        }
        let mut now = Vec::new();
        self.save_into(&mut now)?;
        let written = self.restore_snapshot(snap).and_then(|()| self.save_into(&mut snap.bytes));
        self.restore_from(&now)?;
        written?;
        if let Some(m) = snap.memory.as_mut() {
            m.bytes_current = true;
        }
        Ok(&snap.bytes)
    }

    /// Replaces `out` with the serialized current state.
    pub(crate) fn save_into(&mut self, out: &mut Vec<u8>) -> Result<(), String> {
        out.clear();
        out.extend_from_slice(STATE_MAGIC);
        let header = Header {
            guid: &self.info.description.guid,
            phase: self.phase,
            time: self.time,
            start_time: self.start_time,
            stop_time: self.stop_time,
            terminated: self.terminated,
        };
        append(&header, out)?;
        let model = self.model.save().msg()?;
        append(&model, out)
    }

    /// The saved state in `bytes`, refused unless it is a complete state of this FMU.
    fn parse<'b>(&self, bytes: &'b [u8]) -> Result<Saved<'b, M::State<'b>>, String> {
        let not_ours = |e: postcard::Error| format!("not a state of this FMU: {e}");
        let Some(rest) = bytes.strip_prefix(STATE_MAGIC) else {
            return Err("not a state of this FMU (wrong header)".into());
        };
        let (header, rest) = postcard::take_from_bytes::<Header<'b>>(rest).map_err(not_ours)?;
        if header.guid != self.info.description.guid {
            return Err(format!(
                "the state belongs to an FMU with GUID `{}`, this one has `{}`",
                header.guid, self.info.description.guid
            ));
        }
        if matches!(header.phase, Phase::Error | Phase::Fatal) {
            return Err(format!("not a state of this FMU: phase `{}` is never saved", header.phase.name()));
        }
        Ok(Saved { header, model: decode_all(rest)? })
    }

    /// Refuses bytes that are not a complete state of this FMU (for `fmi2DeSerializeFMUstate`).
    pub(crate) fn check_state(&self, bytes: &[u8]) -> Result<(), String> {
        self.parse(bytes).map(drop)
    }

    pub(crate) fn restore_from(&mut self, bytes: &[u8]) -> Result<(), String> {
        let Saved { header: h, model } = self.parse(bytes)?;
        self.model.restore(model).msg()?;
        (self.phase, self.time, self.start_time, self.stop_time, self.terminated) =
            (h.phase, h.time, h.start_time, h.stop_time, h.terminated);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize, Deserialize)]
    struct WithReals<'a> {
        before: u8,
        #[serde(borrow)]
        numbers: Reals<'a>,
        after: f64,
    }

    #[test]
    fn reals_round_trip_bit_for_bit_as_one_block() {
        let numbers = [f64::from_bits(0x7ff8_0000_dead_beef), -0.0, f64::MIN_POSITIVE / 4.0, 1.0 / 3.0, -1e300];
        let mut bytes = Vec::new();
        append(&WithReals { before: 7, numbers: Reals::new(&numbers), after: 2.5 }, &mut bytes).unwrap();
        // One byte, the length (40) as one varint byte, 40 bytes of numbers, 8 bytes for `after`.
        assert_eq!(bytes.len(), 1 + 1 + 40 + 8);
        let back: WithReals = decode_all(&bytes).unwrap();
        assert_eq!((back.before, back.after, back.numbers.len()), (7, 2.5, 5));
        let mut out = vec![9.0; 2];
        back.numbers.copy_into(&mut out);
        assert_eq!(out.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), numbers.map(f64::to_bits));
        // Saved again from the restored form: the same bytes.
        let mut again = Vec::new();
        append(&back, &mut again).unwrap();
        assert_eq!(again, bytes);
    }

    #[test]
    fn reals_refuse_a_partial_number() {
        // `before`, then a block of 7 bytes, then 8 bytes.
        let bytes = [[7u8, 7].as_slice(), &[0; 7], &[0; 8]].concat();
        let e = decode_all::<WithReals>(&bytes).err().unwrap();
        assert!(e.contains("not a state of this FMU"), "{e}");
    }

    #[test]
    fn only_snapshots_with_the_tag_are_taken() {
        let foreign = Box::into_raw(Box::new(Snapshot { tag: 1, bytes: vec![], memory: None }));
        // SAFETY: a live Snapshot (with the wrong tag), used by nothing else.
        let e = unsafe { snapshot_mut(foreign.cast()) }.err().unwrap();
        assert!(e.contains("does not point to a live FMU state"), "{e}");
        // SAFETY: made by Box::into_raw above, freed once.
        drop(unsafe { Box::from_raw(foreign) });
        let ours = Snapshot::of_bytes(vec![1, 2]).into_raw();
        // SAFETY: made by Snapshot::into_raw, not freed yet.
        assert_eq!(unsafe { snapshot_mut(ours) }.unwrap().bytes, [1, 2]);
        // SAFETY: as above; not used afterwards.
        unsafe { free_snapshot(ours) }.unwrap();
        // SAFETY: null is allowed.
        assert!(unsafe { snapshot_mut(std::ptr::null_mut()) }.is_err());
    }
}
