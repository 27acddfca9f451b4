//! What an FMU logs: the C shim formats its printf-style messages, a sink per instance keeps them.

use std::collections::VecDeque;
use std::ffi::{CStr, c_char, c_void};
use std::sync::Mutex;

use crate::ffi::*;

// SAFETY: the declarations match their definitions: the shim in `csrc/logger.c` (compiled by
// build.rs) and the C library's `calloc`/`free`.
unsafe extern "C" {
    /// The C shim in `csrc/logger.c`.
    fn fmi2rs_logger(
        env: *mut c_void,
        instance: fmi2String,
        status: fmi2Status,
        category: fmi2String,
        message: fmi2String,
        ...
    );
    fn calloc(n: usize, size: usize) -> *mut c_void;
    fn free(p: *mut c_void);
}

/// One message an FMU logged.
#[derive(Clone, Debug, PartialEq)]
pub struct LogMessage {
    /// The `fmi2Status` the FMU gave with the message.
    pub status: fmi2Status,
    pub category: String,
    pub text: String,
}

/// How many messages an instance keeps (the oldest are dropped).
const LOG_CAPACITY: usize = 256;

/// `componentEnvironment`: the C shim calls `sink` (the first field) with the formatted text.
#[repr(C)]
pub(crate) struct LogSink {
    sink: unsafe extern "C" fn(*mut c_void, fmi2String, fmi2Status, fmi2String, fmi2String),
    messages: Mutex<VecDeque<LogMessage>>,
    echo: bool,
}

impl LogSink {
    pub(crate) fn new() -> Box<LogSink> {
        Box::new(LogSink {
            sink: log_sink,
            messages: Mutex::new(VecDeque::new()),
            echo: std::env::var_os("FMI2_ECHO_LOG").is_some(),
        })
    }

    /// The callbacks an FMU gets: this sink as componentEnvironment, libc's allocator.
    /// The sink must stay where it is (it is boxed) and outlive every instance that uses them.
    pub(crate) fn callbacks(&self) -> fmi2CallbackFunctions {
        fmi2CallbackFunctions {
            logger: Some(fmi2rs_logger),
            allocateMemory: Some(calloc),
            freeMemory: Some(free),
            stepFinished: None,
            componentEnvironment: (self as *const LogSink).cast_mut().cast(),
        }
    }

    /// FMI 3.0's `instanceEnvironment` and `logMessage`: this sink and [`log_sink3`]. The sink
    /// must stay where it is (it is boxed) and outlive every instance that uses them.
    pub(crate) fn fmi3_logger(&self) -> (*mut c_void, crate::fmi3::ffi::fmi3LogMessageCallback) {
        ((self as *const LogSink).cast_mut().cast(), Some(log_sink3))
    }

    /// Take all messages logged so far.
    pub(crate) fn take(&self) -> Vec<LogMessage> {
        self.messages.lock().unwrap_or_else(|p| p.into_inner()).drain(..).collect()
    }

    /// The last few messages, newest last, for error reports; each cut to
    /// [`REPORTED_CHARACTERS`] (an FMU may quote a long parameter value back).
    pub(crate) fn recent(&self) -> Vec<String> {
        let m = self.messages.lock().unwrap_or_else(|p| p.into_inner());
        m.iter().rev().take(5).rev().map(|x| format!("[{}] {}", x.category, cut(&x.text))).collect()
    }
}

/// The most of one logged message an error report quotes.
pub(crate) const REPORTED_CHARACTERS: usize = 1000;

/// `text`, or its first [`REPORTED_CHARACTERS`] characters and how long it was.
fn cut(text: &str) -> std::borrow::Cow<'_, str> {
    match text.char_indices().nth(REPORTED_CHARACTERS) {
        None => text.into(),
        Some((end, _)) => format!("{}… ({} characters in all)", &text[..end], text.chars().count()).into(),
    }
}

/// What the C shim calls with the formatted message.
///
/// # Safety
/// `env` is the componentEnvironment of [`LogSink::callbacks`], so a live `LogSink`; the strings
/// are null or NUL-terminated (the shim passes the FMU's own and its formatted text).
unsafe extern "C" fn log_sink(
    env: *mut c_void,
    instance: fmi2String,
    status: fmi2Status,
    category: fmi2String,
    message: fmi2String,
) {
    // SAFETY: the contract of this function is `record`'s.
    unsafe { record(env, instance, status, category, message) }
}

/// What an FMI 3.0 FMU calls as `logMessage` (the message is plain text).
///
/// # Safety
/// `env` is the instanceEnvironment of [`LogSink::fmi3_logger`], so a live `LogSink`; the strings
/// are null or NUL-terminated.
unsafe extern "C" fn log_sink3(env: *mut c_void, status: fmi2Status, category: fmi2String, message: fmi2String) {
    // SAFETY: the contract of this function is `record`'s.
    unsafe { record(env, std::ptr::null(), status, category, message) }
}

/// Keeps one message in the sink `env` (and echoes it if asked).
///
/// # Safety
/// `env` is a live `LogSink`; the strings are null or NUL-terminated.
unsafe fn record(
    env: *mut c_void,
    instance: fmi2String,
    status: fmi2Status,
    category: fmi2String,
    message: fmi2String,
) {
    let text = |p: *const c_char| {
        // SAFETY: a non-null string is NUL-terminated (the contract).
        if p.is_null() { String::new() } else { unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned() }
    };
    // Never unwind into the FMU (a payload that panics when dropped is forgotten).
    let caught = std::panic::catch_unwind(|| {
        // SAFETY: `env` is a live `LogSink` (the contract), only read here (messages are behind a mutex).
        let sink = unsafe { &*env.cast::<LogSink>() };
        let msg = LogMessage { status, category: text(category), text: text(message) };
        if sink.echo {
            eprintln!("[{}] {} {}: {}", text(instance), msg.status, msg.category, msg.text);
        }
        let mut m = sink.messages.lock().unwrap_or_else(|p| p.into_inner());
        if m.len() == LOG_CAPACITY {
            m.pop_front();
        }
        m.push_back(msg);
    });
    if let Err(payload) = caught {
        std::mem::forget(payload);
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn long_messages_are_cut_in_reports() {
        assert_eq!(super::cut("short"), "short");
        let long = "é".repeat(1500);
        let c = super::cut(&long);
        assert!(c.starts_with(&"é".repeat(1000)) && c.ends_with("… (1500 characters in all)"), "{c}");
    }
}
