//! Panics inside dependencies (mcap's reader, rapier) that the readers catch and turn into
//! typed errors: [`catch`] marks the running thread while it runs a section that may panic,
//! and a panic hook installed by the program ([`install_hook`]: the CLI, the Python module)
//! stays quiet for panics inside such a section — their message travels in the error instead
//! of reaching stderr as several lines of Rust panic text before the one-line error.

use std::cell::Cell;
use std::panic::{catch_unwind, AssertUnwindSafe, PanicHookInfo};

thread_local! {
    /// How many [`catch`] sections the current thread is inside.
    static CATCHING: Cell<u32> = const { Cell::new(0) };
}

/// True while the current thread runs inside [`catch`]: a panic here will be caught and
/// reported as an error value.
pub fn is_catching() -> bool {
    CATCHING.with(|c| c.get() > 0)
}

/// Runs `f`, catching a panic: `Err` carries the panic's message (as the panic gave it; see
/// [`one_line`]).
pub fn catch<R>(f: impl FnOnce() -> R) -> Result<R, String> {
    struct Mark;
    impl Drop for Mark {
        fn drop(&mut self) {
            CATCHING.with(|c| c.set(c.get().saturating_sub(1)));
        }
    }
    CATCHING.with(|c| c.set(c.get().saturating_add(1)));
    let mark = Mark;
    let result = catch_unwind(AssertUnwindSafe(f));
    drop(mark);
    result.map_err(|payload| {
        payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic without a message".to_string())
    })
}

/// `text` on one line: line breaks become "; ", terminal escape sequences (colours) and other
/// control characters go.
pub fn one_line(text: &str) -> String {
    let mut plain = String::with_capacity(text.len());
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        if c == '\u{1b}' {
            // CSI sequence: ESC [ parameters final-byte (0x40..=0x7e).
            if chars.next() == Some('[') {
                for c in chars.by_ref() {
                    if ('\u{40}'..='\u{7e}').contains(&c) {
                        break;
                    }
                }
            }
        } else {
            plain.push(c);
        }
    }
    plain
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
        .chars()
        .filter(|c| !c.is_control())
        .collect()
}

/// The panic's message and location on one line, e.g. `panicked at src/x.rs:3:5: boom`.
pub fn describe(info: &PanicHookInfo<'_>) -> String {
    let payload = info.payload();
    let message = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".to_string());
    match info.location() {
        Some(at) => one_line(&format!("panicked at {at}: {message}")),
        None => one_line(&format!("panicked: {message}")),
    }
}

/// Installs a process-wide panic hook that says nothing about panics inside [`catch`] (they
/// become errors) and hands every other panic to `unexpected`.
pub fn install_hook(unexpected: Box<dyn Fn(&PanicHookInfo<'_>) + Send + Sync + 'static>) {
    std::panic::set_hook(Box::new(move |info| {
        if !is_catching() {
            unexpected(info);
        }
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catch_returns_the_value_or_the_message_on_one_line() {
        assert_eq!(catch(|| 3), Ok(3));
        let e =
            catch(|| -> u8 { panic!("two\nlines \u{1b}[31mred\u{1b}[0m") }).expect_err("panics");
        assert_eq!(e, "two\nlines \u{1b}[31mred\u{1b}[0m");
        assert_eq!(one_line(&e), "two; lines red");
        assert!(!is_catching(), "the mark is gone after a panic");
    }

    #[test]
    fn the_mark_nests_and_is_per_thread() {
        assert!(!is_catching());
        let inner = catch(|| {
            let nested = catch(is_catching).expect("no panic");
            let other = std::thread::spawn(is_catching).join().expect("thread");
            (nested, is_catching(), other)
        });
        assert_eq!(inner, Ok((true, true, false)));
        assert!(!is_catching());
    }
}
