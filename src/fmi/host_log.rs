//! A log capture for Rust programs that host an FMU through the C ABI: the crate's tests and
//! examples, which call the `fmi2*` functions as a C host would and read what the FMU logs.
//!
//! The FMI logger is variadic, which stable Rust cannot define. The capture's logger is a
//! non-variadic `extern "C"` function with one extra `*const c_char` parameter, transmuted to
//! the variadic pointer type: on x86_64 System V and AArch64 Linux, the first variadic pointer
//! argument travels in the same register as a sixth fixed pointer argument, so the logger reads
//! the text that follows the `"%s"` format (this crate's FMU always logs `"%s"` plus the text,
//! so a message's `%` signs are never interpreted). Hence the module exists on those targets
//! only. The FMU itself never uses it.

use super::ffi::{fmi2CallbackFunctions, fmi2OK, fmi2Status, fmi2String};
use std::ffi::{c_char, c_void, CStr};
use std::sync::Mutex;

/// One message the FMU sent to the logger.
#[derive(Clone, Debug, PartialEq)]
pub struct Logged {
    /// The instance name the FMU gave.
    pub instance: String,
    /// Status of the message.
    pub status: fmi2Status,
    /// Category.
    pub category: String,
    /// The format argument (`"%s"` from this crate's FMU).
    pub format: String,
    /// The text.
    pub message: String,
}

/// What the logger of [`LogCapture::callbacks`] collects. Keep it alive and in place while an
/// instance made with those callbacks lives: the callbacks point at it.
#[derive(Default, Debug)]
pub struct LogCapture(Mutex<Vec<Logged>>);

impl LogCapture {
    /// FMI callbacks whose logger records into this capture (no memory callbacks: FMI 2.0
    /// FMUs that need them are not this crate's).
    pub fn callbacks(&self) -> fmi2CallbackFunctions {
        type Fixed = unsafe extern "C" fn(
            *mut c_void,
            fmi2String,
            fmi2Status,
            fmi2String,
            fmi2String,
            *const c_char,
        );
        type Variadic =
            unsafe extern "C" fn(*mut c_void, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
        // SAFETY: see the module documentation: the arguments read travel in the same
        // registers on the targets this module is compiled for.
        let logger = unsafe { std::mem::transmute::<Fixed, Variadic>(record) };
        fmi2CallbackFunctions {
            logger: Some(logger),
            allocateMemory: None,
            freeMemory: None,
            stepFinished: None,
            componentEnvironment: self as *const LogCapture as *mut c_void,
        }
    }

    /// Everything logged so far.
    pub fn all(&self) -> Vec<Logged> {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    /// The last message, or an empty one with status OK.
    pub fn last(&self) -> Logged {
        self.all().last().cloned().unwrap_or(Logged {
            instance: String::new(),
            status: fmi2OK,
            category: String::new(),
            format: String::new(),
            message: String::new(),
        })
    }

    /// Number of messages so far.
    pub fn len(&self) -> usize {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// Whether nothing was logged.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Messages after the first `from`.
    pub fn since(&self, from: usize) -> Vec<Logged> {
        self.all().into_iter().skip(from).collect()
    }
}

/// # Safety
/// `p` is null or a NUL-terminated string.
unsafe fn text(p: *const c_char) -> String {
    if p.is_null() {
        "<NULL>".into()
    } else {
        unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
    }
}

/// The logger: `env` is the [`LogCapture`] of the callbacks.
unsafe extern "C" fn record(
    env: *mut c_void,
    instance: fmi2String,
    status: fmi2Status,
    category: fmi2String,
    format: fmi2String,
    arg: *const c_char,
) {
    // A panic must not unwind into the FMU's C frames: the body runs behind a guard, and a
    // message that could not be recorded is lost rather than the process aborted.
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        // SAFETY: the callbacks carry a pointer to a live capture (see
        // `LogCapture::callbacks`); the strings are the FMU's NUL-terminated arguments.
        let capture = unsafe { &*(env as *const LogCapture) };
        let logged = unsafe {
            Logged {
                instance: text(instance),
                status,
                category: text(category),
                format: text(format),
                message: text(arg),
            }
        };
        capture
            .0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(logged);
    }));
}
