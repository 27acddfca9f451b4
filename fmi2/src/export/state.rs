//! Saved FMU states: what an `fmi2FMUstate` points to, and its bytes.
//!
//! A state is stored in its serialized form, so get/set and (de)serialize share one mechanism:
//! `FMI2RSv2` (8 bytes), then postcard's encoding of the layer's [`Header`] and of the model's
//! [`Model::State`]. postcard writes an f64 as its 8 little-endian bytes, so a rollback
//! reproduces every number bit for bit; it refuses truncated input, invalid tags, booleans and
//! UTF-8, and we refuse trailing bytes, so random or foreign bytes are rejected with a message.

use serde::{Deserialize, Serialize};

use super::Model;
use super::instance::{Instance, Msg, Phase};
use crate::ffi::fmi2FMUstate;

/// First bytes of every saved state of this layer (format 2: postcard).
const STATE_MAGIC: &[u8; 8] = b"FMI2RSv2";
/// First field of every [`Snapshot`] this layer allocates.
const SNAPSHOT_TAG: u64 = 0x5253_5441_5445_4d49;

/// What an `fmi2FMUstate` of this layer points to.
pub(crate) struct Snapshot {
    tag: u64,
    pub(crate) bytes: Vec<u8>,
}

impl Snapshot {
    /// A new snapshot on the heap, as the importer's opaque `fmi2FMUstate`.
    pub(crate) fn into_raw(bytes: Vec<u8>) -> fmi2FMUstate {
        Box::into_raw(Box::new(Snapshot { tag: SNAPSHOT_TAG, bytes })).cast()
    }
}

/// The snapshot an `fmi2FMUstate` points to. The tag check catches a state that this layer
/// made and an importer passes by mistake after freeing it (while the memory still holds the
/// tag, the best a C API allows) or that another FMU of this layer made; it cannot catch a
/// pointer to something else entirely, since reading its first eight bytes is already
/// undefined behaviour: no check inside the FMU can make a foreign pointer safe.
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
        return Err("`FMUstate` is not a state of this FMU (already freed, or made by another FMU)".into());
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
    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        self.0.extend_from_slice(data);
        Ok(())
    }
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

/// The layer's fields and the model's state, checked (a state of this FMU, every byte used).
struct Saved<'b, S> {
    header: Header<'b>,
    model: S,
}

impl<M: Model> Instance<M> {
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
