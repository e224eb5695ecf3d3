//! The link's framing: how one message travels on the byte stream.
//!
//! Wire convention: a frame is the message's postcard bytes, COBS-encoded (no
//! `0x00` inside), then one `0x00` delimiter ([`encode`]); at most
//! [`MAX_FRAME`] bytes with the delimiter. The receiver splits the stream at
//! each `0x00` ([`FrameBuffer`]) and ignores empty frames, so a sender may open
//! with a lone `0x00` to end a partial frame left on the line. A frame that is
//! too long, is not valid COBS, does not decode as one message or has bytes
//! left after it is refused ([`decode`], [`FrameError`]).
//!
//! Units: bytes.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// The largest encoded frame, bytes, delimiter included: the largest message
/// (a full chunk, under 140 bytes of postcard) plus COBS' overhead, with room.
pub const MAX_FRAME: usize = 256;

/// The frame of [`Request::Halt`](super::Request::Halt), for scripts that end
/// a controller session without a host program (`firmware/qemu-run.sh`).
pub const HALT_FRAME: [u8; 3] = [0x02, 0x03, 0x00];

/// Why a frame was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FrameError {
    /// More than [`MAX_FRAME`] bytes before the delimiter.
    TooLong,
    /// Not valid COBS.
    Cobs,
    /// Not a message of the expected type, or bytes left after it.
    Message,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::TooLong => "frame too long",
            Self::Cobs => "frame is not valid COBS",
            Self::Message => "frame does not hold one whole message",
        })
    }
}

/// Why a message could not be encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EncodeError;

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "message does not fit a frame of {MAX_FRAME} bytes")
    }
}

/// Encodes `message` as a frame into `buf`: postcard, COBS, the `0x00`
/// delimiter. Returns the frame's bytes.
pub fn encode<'a, T: Serialize>(
    message: &T,
    buf: &'a mut [u8],
) -> Result<&'a mut [u8], EncodeError> {
    let n = buf.len().min(MAX_FRAME);
    postcard::to_slice_cobs(message, &mut buf[..n]).map_err(|_| EncodeError)
}

/// Decodes one frame (its bytes before the delimiter, COBS-encoded; decoded in
/// place) as a `T`. Refuses anything but exactly one whole message.
pub fn decode<T: DeserializeOwned>(frame: &mut [u8]) -> Result<T, FrameError> {
    if frame.len() >= MAX_FRAME {
        return Err(FrameError::TooLong);
    }
    let n = cobs::decode_in_place(frame).map_err(|_| FrameError::Cobs)?;
    let (message, rest) =
        postcard::take_from_bytes::<T>(&frame[..n]).map_err(|_| FrameError::Message)?;
    if !rest.is_empty() {
        return Err(FrameError::Message);
    }
    Ok(message)
}

/// Splits a byte stream into frames at each `0x00`.
#[derive(Clone, Debug)]
pub struct FrameBuffer {
    buf: [u8; MAX_FRAME],
    len: usize,
    overflow: bool,
}

impl Default for FrameBuffer {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameBuffer {
    /// An empty buffer.
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            len: 0,
            overflow: false,
        }
    }

    /// Takes one byte. At a delimiter ending a non-empty frame, returns the frame's
    /// bytes (COBS, without the delimiter) for [`decode`], or
    /// [`FrameError::TooLong`] if it overflowed the buffer.
    pub fn push(&mut self, byte: u8) -> Option<Result<&mut [u8], FrameError>> {
        if byte != 0 {
            if self.len < self.buf.len() {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        let (len, overflow) = (self.len, self.overflow);
        self.len = 0;
        self.overflow = false;
        if overflow {
            Some(Err(FrameError::TooLong))
        } else if len == 0 {
            None
        } else {
            Some(Ok(&mut self.buf[..len]))
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use std::vec;

    use super::*;
    use crate::MAX_JOINTS;
    use crate::link::Request;
    use crate::link::wire::tests::command;

    /// Malformed frames are refused with their reason, never decoded as something else.
    #[test]
    fn malformed_frames_are_refused() {
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode(&Request::Command(command(3, &[0.1; 6])), &mut buf).unwrap();
        let body = frame[..frame.len() - 1].to_vec();
        // Truncated: the message ends early.
        let mut cut = body[..body.len() - 3].to_vec();
        assert!(decode::<Request>(&mut cut).is_err());
        // A COBS code byte pointing past the end.
        let mut bad = vec![0x09, 1, 2];
        assert_eq!(decode::<Request>(&mut bad), Err(FrameError::Cobs));
        // An unknown message tag.
        let mut unknown = vec![0x02, 0x63];
        assert_eq!(decode::<Request>(&mut unknown), Err(FrameError::Message));
        // A whole message with a byte after it.
        let mut plain = [0u8; 64];
        let n = postcard::to_slice(&Request::Status, &mut plain)
            .unwrap()
            .len();
        let mut extra = [0u8; 66];
        let extended = [&plain[..n], &[7u8]].concat();
        let m = cobs::encode(&extended, &mut extra);
        assert_eq!(decode::<Request>(&mut extra[..m]), Err(FrameError::Message));
        // A joint vector longer than MAX_JOINTS (postcard: tag, seq, length,
        // the values, no context), beside the same with MAX_JOINTS values.
        let command_of = |n: usize| {
            let mut raw = vec![1u8, 0, n as u8];
            raw.extend(vec![0u8; 4 * n]);
            raw.push(0);
            let mut enc = [0u8; MAX_FRAME];
            let m = cobs::encode(&raw, &mut enc);
            decode::<Request>(&mut enc[..m])
        };
        assert!(command_of(MAX_JOINTS).is_ok());
        assert_eq!(command_of(MAX_JOINTS + 1), Err(FrameError::Message));
        // A frame that overflows the receiver: refused at its delimiter, and the
        // next frame is read normally.
        let mut rx = FrameBuffer::new();
        for _ in 0..MAX_FRAME + 10 {
            assert!(rx.push(0x55).is_none());
        }
        assert_eq!(
            rx.push(0).map(|r| r.map(|_| ())),
            Some(Err(FrameError::TooLong))
        );
        assert!(rx.push(0).is_none(), "an empty frame is ignored");
        let mut got = None;
        for &b in frame.iter() {
            if let Some(f) = rx.push(b) {
                got = Some(decode::<Request>(f.unwrap()));
            }
        }
        assert_eq!(got, Some(Ok(Request::Command(command(3, &[0.1; 6])))));
    }
}
