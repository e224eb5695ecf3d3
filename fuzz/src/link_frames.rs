//! `link_frames`: the serial link's receiver, `FrameBuffer` and `decode`.
//!
//! The input is a byte stream as the line delivers it. Asserts: no panic; and
//! - `FrameBuffer` splits it exactly as a reference splitter does: at each
//!   `0x00`, empty frames ignored, a frame of more than `MAX_FRAME` bytes
//!   refused as `TooLong` (and the next frame read normally);
//! - each frame is decoded both as a `Request` (the controller's side) and as
//!   a `Response` (the host's side); a frame that decodes is re-encoded by
//!   `encode` (it fits a frame), the encoding is a well-formed frame (one
//!   `0x00`, at its end), decodes again and re-encodes to the same bytes.

use armcal_shared::link::{self, FrameBuffer, FrameError, MAX_FRAME, Request, Response};
use serde::Serialize;
use serde::de::DeserializeOwned;

/// The harness; see [the module](self). Returns how many frames decoded as a
/// request or a response (for the tests of the seeds).
pub fn run(data: &[u8]) -> usize {
    let mut decoded = 0;
    // The reference: the frames between delimiters, without the last partial one.
    let mut expected: Vec<Result<&[u8], FrameError>> = Vec::new();
    let mut pieces: Vec<&[u8]> = data.split(|&b| b == 0).collect();
    pieces.pop(); // Not (yet) terminated by a delimiter.
    for piece in pieces {
        if piece.len() > MAX_FRAME {
            expected.push(Err(FrameError::TooLong));
        } else if !piece.is_empty() {
            expected.push(Ok(piece));
        }
    }
    let mut rx = FrameBuffer::new();
    let mut got = 0;
    for &byte in data {
        let Some(frame) = rx.push(byte) else {
            continue;
        };
        let want = expected.get(got).copied();
        got += 1;
        match (frame, want) {
            (Err(e), Some(Err(w))) => assert_eq!(e, w),
            (Ok(frame), Some(Ok(w))) => {
                assert_eq!(&frame[..], w, "the frame's bytes");
                let mut copy = w.to_vec();
                decoded += usize::from(check::<Request>(frame));
                // `decode` works in place: the response reading needs the bytes again.
                decoded += usize::from(check::<Response>(&mut copy));
            }
            (frame, want) => panic!("FrameBuffer gave {frame:?}, the reference {want:?}"),
        }
    }
    assert_eq!(got, expected.len(), "frames missed by FrameBuffer");
    decoded
}

/// Whether `frame` decodes as a `T`; if it does, the checks of [the module](self).
fn check<T: Serialize + DeserializeOwned + core::fmt::Debug>(frame: &mut [u8]) -> bool {
    let len = frame.len();
    let Ok(message) = link::decode::<T>(frame) else {
        return false;
    };
    assert!(len < MAX_FRAME, "decoded a frame of {len} bytes");
    let mut buf = [0u8; MAX_FRAME];
    let encoded = match link::encode(&message, &mut buf) {
        Ok(bytes) => bytes.to_vec(),
        Err(e) => panic!("{message:?} decoded from {len} bytes does not encode: {e}"),
    };
    let (last, body) = encoded.split_last().expect("not empty");
    assert_eq!(*last, 0, "a frame ends with its delimiter");
    assert!(!body.contains(&0), "no 0x00 inside a frame");
    let mut body = body.to_vec();
    let again = link::decode::<T>(&mut body).expect("the encoding decodes");
    let mut buf2 = [0u8; MAX_FRAME];
    assert_eq!(
        link::encode(&again, &mut buf2).expect("encodes"),
        &encoded[..],
        "decode -> encode is not stable"
    );
    true
}
