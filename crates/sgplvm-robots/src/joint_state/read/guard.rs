//! What corrupt input becomes: the mcap reader's panics caught, every string length of a
//! record checked before mcap's parser reserves it, and the parser's multi-line backtraces
//! turned into one plain line for the error message.

use ::mcap::records::op;
use ::mcap::sans_io::LinearReadEvent;
use ::mcap::sans_io::LinearReader;
use ::mcap::McapError;

/// The reader's next event. mcap 0.26 can panic on inconsistent chunk contents (an arithmetic
/// overflow when a record inside an uncompressed chunk without CRC claims more bytes than the
/// chunk has, in builds with overflow checks): that panic is caught and becomes an error.
pub(super) fn next_event(
    reader: &mut LinearReader,
) -> std::result::Result<Option<std::result::Result<LinearReadEvent<'_>, McapError>>, String> {
    crate::panics::catch(move || {
        let reader = reader;
        reader.next_event()
    })
    .map_err(|what| {
        format!(
            "inconsistent chunk contents (the mcap reader stopped: {})",
            plain_line(&what)
        )
    })
}

/// Checks that every string (and string map) of a Schema, Channel or Metadata record fits in
/// the record, so that parsing it allocates at most the record's size. A record too short for
/// a length field is left to mcap's parser, which reports it.
pub(super) fn strings_fit(opcode: u8, data: &[u8]) -> std::result::Result<(), String> {
    struct Fields<'d> {
        data: &'d [u8],
        at: usize,
        record: &'static str,
    }
    impl Fields<'_> {
        fn u32(&mut self) -> Option<usize> {
            let b = self.data.get(self.at..self.at.checked_add(4)?)?;
            self.at += 4;
            usize::try_from(u32::from_le_bytes(b.try_into().ok()?)).ok()
        }
        fn string(&mut self, what: &str) -> std::result::Result<Option<()>, String> {
            let Some(len) = self.u32() else {
                return Ok(None);
            };
            let remain = self.data.len() - self.at;
            if len > remain {
                return Err(format!(
                    "{} record: {what} declares {len} bytes, only {remain} remain in the record",
                    self.record
                ));
            }
            self.at += len;
            Ok(Some(()))
        }
        fn map(&mut self, what: &str) -> std::result::Result<Option<()>, String> {
            let Some(byte_len) = self.u32() else {
                return Ok(None);
            };
            let start = self.at;
            while self.at - start < byte_len {
                if self.string(what)?.is_none() || self.string(what)?.is_none() {
                    return Ok(None);
                }
            }
            Ok(Some(()))
        }
    }
    let mut f = Fields {
        data,
        at: 0,
        record: "",
    };
    match opcode {
        op::SCHEMA => {
            f.record = "Schema";
            f.at = 2;
            if f.string("the name")?.is_some() {
                f.string("the encoding")?;
            }
        }
        op::CHANNEL => {
            f.record = "Channel";
            f.at = 4;
            if f.string("the topic")?.is_some() && f.string("the message encoding")?.is_some() {
                f.map("a metadata string")?;
            }
        }
        op::METADATA => {
            f.record = "Metadata";
            if f.string("the name")?.is_some() {
                f.map("a metadata string")?;
            }
        }
        _ => {}
    }
    Ok(())
}

/// `text` on one plain line: without terminal escape sequences, decoration lines, source
/// locations (`at /path/file.rs:123`) and frame numbers, its remaining lines joined by "; ".
/// binrw prints its errors as a coloured multi-line backtrace; this keeps what it says
/// ("failed to fill whole buffer; while parsing field 'metadata' in Channel").
pub(super) fn plain_line(text: &str) -> String {
    let mut clean = String::with_capacity(text.len().min(4096));
    let mut chars = text.chars();
    while let Some(c) = chars.next() {
        match c {
            '\u{1b}' => {
                // CSI sequence: ESC [ parameters final-byte (0x40..=0x7e).
                if chars.next() == Some('[') {
                    for c in chars.by_ref() {
                        if ('\u{40}'..='\u{7e}').contains(&c) {
                            break;
                        }
                    }
                }
            }
            '\n' => clean.push('\n'),
            c if c.is_control() => {}
            c => clean.push(c),
        }
    }
    let mut parts: Vec<String> = Vec::new();
    for line in clean.lines() {
        let mut line = line.trim();
        if line.is_empty()
            || line.starts_with("at ")
            || !line.starts_with(|c: char| c.is_alphanumeric() || c == '`' || c == '\'')
        {
            continue;
        }
        // Frame numbers "0: ".
        if let Some((n, rest)) = line.split_once(": ") {
            if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) {
                line = rest.trim();
            }
        }
        let line = line.strip_prefix("Error: ").unwrap_or(line);
        let line = match line.strip_prefix("While ") {
            Some(rest) => format!("while {rest}"),
            None => line.to_string(),
        };
        if !line.is_empty() && !parts.contains(&line) {
            parts.push(line);
        }
    }
    let mut out = parts.join("; ");
    if out.len() > 300 {
        let cut = (0..=300)
            .rev()
            .find(|&i| out.is_char_boundary(i))
            .unwrap_or(0);
        out.truncate(cut);
        out.push('…');
    }
    out
}

#[cfg(test)]
mod plain_line_tests {
    #[test]
    fn binrw_backtraces_become_one_plain_line() {
        let raw = "\n ╺━━━━┅ Backtrace ┅━━━━╸\n\n 0: \u{1b}[1m\u{1b}[1mError: failed to fill whole buffer\u{1b}[22m\n           \u{1b}[1mWhile parsing field 'offset' in MessageIndexEntry\u{1b}[22m\u{1b}[22m\n     at /root/.cargo/registry/src/x/mcap-0.26.0/src/records.rs:373\n 1: \u{1b}[1mWhile parsing field 'records' in MessageIndex\u{1b}[22m\n     at /root/.cargo/registry/src/x/mcap-0.26.0/src/records.rs:382\n\n ╺━━━━╸\n\n";
        assert_eq!(
            super::plain_line(raw),
            "failed to fill whole buffer; while parsing field 'offset' in MessageIndexEntry; while parsing field 'records' in MessageIndex"
        );
        assert_eq!(
            super::plain_line("Data corruption detected"),
            "Data corruption detected"
        );
    }
}
