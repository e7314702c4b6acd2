//! The messages of a log, one at a time, before its parser sees them: where a message ends is
//! all this knows of either format (a ULog's size field, a DataFlash type's declared length).
//!
//! Why the bytes are walked here and not only by the parsers: neither says where a log stops
//! being readable. At a power cut's torn last message `yule_log` returns the message with its
//! missing bytes as zeros and `ardupilot-binlog` skips ahead to the next header it can find,
//! returning whatever it straddles as a message. Walking the frames first, the damage is named
//! with its byte offset and only whole messages reach the parser. It also lets the parser see
//! only the messages a calibration reads (a long log's other topics are skipped unparsed), and it
//! counts the bytes read for the progress bar.

use std::cell::RefCell;
use std::fs::File;
use std::io::{BufReader, Read};
use std::rc::Rc;

use super::error::{Damage, Progress};

/// What one frame is.
pub(super) enum Frame {
    /// A whole message, its bytes, and whether the parser needs it.
    Message(Vec<u8>, bool),
    /// The file ends cleanly here.
    End,
}

/// A format's framing: the next message at `offset` of `r`, or why none can be read there.
pub(super) trait Framing {
    /// The next frame; `Err` names the damage found (its offset is the caller's).
    fn next(&mut self, r: &mut impl Read) -> Result<Frame, String>;
}

/// Reads up to `buf.len()` bytes, fewer only at the file's end: how many were read.
pub(super) fn read_full(r: &mut impl Read, buf: &mut [u8]) -> Result<usize, String> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(format!("read error: {e}")),
        }
    }
    Ok(n)
}

/// The whole messages a parser needs, as one byte stream: a `Read` over the file that walks its
/// frames, passes on the kept ones, and stops at the first damage, recorded in `damage`.
pub(super) struct Filtered<'p, F> {
    file: BufReader<File>,
    framing: F,
    offset: u64,
    total: u64,
    pending: Vec<u8>,
    at: usize,
    done: bool,
    damage: Rc<RefCell<Option<Damage>>>,
    progress: Progress<'p>,
}

impl<'p, F: Framing> Filtered<'p, F> {
    /// Walks `file` (of `total` bytes) with `framing`; the damage found is left in `damage`.
    pub(super) fn new(
        file: File,
        total: u64,
        framing: F,
        damage: Rc<RefCell<Option<Damage>>>,
        progress: Progress<'p>,
    ) -> Self {
        Self {
            file: BufReader::with_capacity(1 << 20, file),
            framing,
            offset: 0,
            total,
            pending: Vec::new(),
            at: 0,
            done: false,
            damage,
            progress,
        }
    }

    /// Fills `pending` with the next kept message; false at the end or the damage.
    fn refill(&mut self) -> bool {
        while !self.done {
            let mut counted = Counted {
                inner: &mut self.file,
                n: 0,
            };
            let frame = self.framing.next(&mut counted);
            let start = self.offset;
            self.offset += counted.n;
            match frame {
                Ok(Frame::Message(bytes, keep)) => {
                    if self.offset >> 22 != start >> 22 {
                        (self.progress)(self.offset, self.total);
                    }
                    if keep {
                        self.pending = bytes;
                        self.at = 0;
                        return true;
                    }
                }
                Ok(Frame::End) => {
                    (self.progress)(self.total, self.total);
                    self.done = true;
                }
                Err(what) => {
                    *self.damage.borrow_mut() = Some(Damage {
                        offset: start,
                        what,
                    });
                    (self.progress)(self.total, self.total);
                    self.done = true;
                }
            }
        }
        false
    }
}

impl<F: Framing> Read for Filtered<'_, F> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.at == self.pending.len() && !self.refill() {
            return Ok(0);
        }
        let n = buf.len().min(self.pending.len() - self.at);
        buf[..n].copy_from_slice(&self.pending[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }
}

/// A reader that counts the bytes it has read.
struct Counted<'a, R> {
    inner: &'a mut R,
    n: u64,
}

impl<R: Read> Read for Counted<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.n += n as u64;
        Ok(n)
    }
}
