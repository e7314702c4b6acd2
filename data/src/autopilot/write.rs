//! Writing the two formats, as far as a simulated flight controller's thermal calibration needs:
//! a ULog's header, formats, subscriptions and samples; a DataFlash log's formats and messages.
//!
//! Written here by hand because neither ecosystem crate offers it in a usable form:
//! `ardupilot-binlog` only reads, and `yule_log`'s encoder re-emits parsed messages (each value
//! built with its parsed format definition), which for a writer is more code than the format.
//! Both layouts are those the readers above read: the ULog specification (docs.px4.io,
//! "ULog File Format") and ArduPilot's `LogStructure.h`.

use std::io::{self, Write};

/// The fields of PX4's `sensor_gyro` and `sensor_accel` topics as a calibration reads them (C
/// type, name), in PX4's order: what the simulated board and the tests write.
pub const PX4_SENSOR_FIELDS: [(&str, &str); 8] = [
    ("uint64_t", "timestamp"),
    ("uint64_t", "timestamp_sample"),
    ("uint32_t", "device_id"),
    ("float", "x"),
    ("float", "y"),
    ("float", "z"),
    ("float", "temperature"),
    ("uint32_t", "error_count"),
];

/// One field's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// `uint8_t`, DataFlash `B`.
    U8(u8),
    /// `uint16_t`, DataFlash `H`.
    U16(u16),
    /// `uint32_t`, DataFlash `I`.
    U32(u32),
    /// `uint64_t`, DataFlash `Q`.
    U64(u64),
    /// `float`, DataFlash `f`.
    F32(f32),
    /// A name of up to 16 bytes, zero-padded: DataFlash `N` (a `PARM` message's `Name`).
    Name([u8; 16]),
}

impl Value {
    /// `text` as a DataFlash `N` field: its first 16 bytes, zero-padded.
    pub fn name(text: &str) -> Self {
        let mut field = [0u8; 16];
        for (f, b) in field.iter_mut().zip(text.bytes()) {
            *f = b;
        }
        Self::Name(field)
    }

    fn bytes(self, out: &mut Vec<u8>) {
        match self {
            Self::U8(v) => out.push(v),
            Self::U16(v) => out.extend_from_slice(&v.to_le_bytes()),
            Self::U32(v) => out.extend_from_slice(&v.to_le_bytes()),
            Self::U64(v) => out.extend_from_slice(&v.to_le_bytes()),
            Self::F32(v) => out.extend_from_slice(&v.to_le_bytes()),
            Self::Name(v) => out.extend_from_slice(&v),
        }
    }
}

/// A ULog being written: header and flags at creation, then formats, subscriptions and samples.
pub struct ULogWriter<W: Write> {
    out: W,
    next_id: u16,
}

impl<W: Write> ULogWriter<W> {
    /// Starts a ULog (version 1) whose logging began at `start_us`.
    pub fn new(mut out: W, start_us: u64) -> io::Result<Self> {
        out.write_all(b"ULog\x01\x12\x35\x01")?;
        out.write_all(&start_us.to_le_bytes())?;
        let mut w = Self { out, next_id: 0 };
        // Flag bits: no compatible or incompatible flag, no appended data.
        w.message(b'B', &[0u8; 40])?;
        Ok(w)
    }

    fn message(&mut self, kind: u8, body: &[u8]) -> io::Result<()> {
        let size = u16::try_from(body.len())
            .map_err(|_| io::Error::other("a ULog message holds at most 65535 bytes"))?;
        self.out.write_all(&size.to_le_bytes())?;
        self.out.write_all(&[kind])?;
        self.out.write_all(body)
    }

    /// Defines a topic's format: `fields` as (C type, name), e.g. `("float", "x")`.
    pub fn format(&mut self, name: &str, fields: &[(&str, &str)]) -> io::Result<()> {
        let text: Vec<String> = fields.iter().map(|(t, n)| format!("{t} {n};")).collect();
        self.message(b'F', format!("{name}:{}", text.concat()).as_bytes())
    }

    /// Subscribes instance `multi` of a topic defined by [`Self::format`]: its message id.
    pub fn subscribe(&mut self, name: &str, multi: u8) -> io::Result<u16> {
        let id = self.next_id;
        self.next_id += 1;
        let mut body = vec![multi];
        body.extend_from_slice(&id.to_le_bytes());
        body.extend_from_slice(name.as_bytes());
        self.message(b'A', &body)?;
        Ok(id)
    }

    /// Writes one sample of subscription `id`, its values in the format's order.
    pub fn data(&mut self, id: u16, values: &[Value]) -> io::Result<()> {
        let mut body = id.to_le_bytes().to_vec();
        for v in values {
            v.bytes(&mut body);
        }
        self.message(b'D', &body)
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.out
    }
}

/// A DataFlash log being written: its formats, then messages of them.
pub struct DataFlashWriter<W: Write> {
    out: W,
}

/// The bytes a DataFlash format character takes.
fn size_of(c: char) -> io::Result<usize> {
    Ok(match c {
        'b' | 'B' | 'M' => 1,
        'h' | 'H' | 'c' | 'C' => 2,
        'i' | 'I' | 'f' | 'e' | 'E' | 'L' | 'n' => 4,
        'q' | 'Q' | 'd' => 8,
        'N' => 16,
        'Z' | 'a' => 64,
        other => return Err(io::Error::other(format!("format character '{other}'"))),
    })
}

impl<W: Write> DataFlashWriter<W> {
    /// Starts a log with the format of formats.
    pub fn new(out: W) -> io::Result<Self> {
        let mut w = Self { out };
        w.define(0x80, "FMT", "BBnNZ", "Type,Length,Name,Format,Labels")?;
        Ok(w)
    }

    /// Defines message type `kind`: its name (at most 4 bytes), format characters and labels.
    pub fn define(&mut self, kind: u8, name: &str, format: &str, labels: &str) -> io::Result<()> {
        let payload: usize = format.chars().map(size_of).sum::<io::Result<usize>>()?;
        let length = u8::try_from(3 + payload)
            .map_err(|_| io::Error::other("a DataFlash message holds at most 255 bytes"))?;
        let mut body = vec![0xA3, 0x95, 0x80, kind, length];
        for (text, width) in [(name, 4), (format, 16), (labels, 64)] {
            let mut field = text.as_bytes().to_vec();
            if field.len() > width {
                return Err(io::Error::other(format!("'{text}' is over {width} bytes")));
            }
            field.resize(width, 0);
            body.extend_from_slice(&field);
        }
        self.out.write_all(&body)
    }

    /// Writes a message of type `kind`, its values in its format's order.
    pub fn write(&mut self, kind: u8, values: &[Value]) -> io::Result<()> {
        let mut body = vec![0xA3, 0x95, kind];
        for v in values {
            v.bytes(&mut body);
        }
        self.out.write_all(&body)
    }

    /// The underlying writer.
    pub fn into_inner(self) -> W {
        self.out
    }
}
