//! `armcal stream`: the host's end of the serial link to the controller
//! (`armcal_shared::link`, where the messages, their framing and the message
//! table are).
//!
//! A session over TCP (`--tcp HOST:PORT`, e.g. QEMU's `-serial tcp:…`) or a
//! serial port (`--serial PATH`, 115 200 baud 8N1 like the firmware, opened with
//! the `serialport` crate built without libudev) runs:
//!
//! 1. `Hello` with a new nonce every [`HELLO_RETRY`] until the answer with the
//!    latest nonce arrives (a booting controller, or a UART that dropped bytes,
//!    costs a retry), at most [`HELLO_TIMEOUT`];
//! 2. the calibration file's bytes, unchanged, in chunks of [`CHUNK_LEN`]; the controller validates the
//!    whole file and accepts it or says why not ([`StreamError::Refused`]);
//! 3. one `Command` per row of the joints file, in order, sequence numbers from
//!    0, with the row's `temp` and `load` as the context; the answer of each is
//!    awaited (lock-step) for at most [`RESPONSE_TIMEOUT`];
//! 4. `Status`, for the counters (faults, deadline misses, worst tick, stack),
//!    then `Ranges`, for the ticks outside the ranges the calibration was
//!    identified on (a controller that predates it refuses the frame: not
//!    reported), and with `--halt` a final `Halt`.
//!
//! Units: rows are read in the calibration's model units and converted to SI;
//! the wire carries SI `f32` (rad, m); the corrected commands are written back
//! in the model's units, `q1..qM`, like `armcal compensate`'s.

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use armcal_shared::Calibration;
use armcal_shared::link::{
    self, CHUNK_LEN, Command, Context, Corrected, FrameBuffer, MAX_FRAME, RangeReport, Rejection,
    Request, Response, StatusReport, TickStatus,
};
use armcal_shared::ranges::Outside;

use crate::apply::compensate;
use crate::session::joints::JointRows;
use armcal_shared::compensation::{Compensator, Limits};

/// How often `Hello` is repeated until answered.
pub const HELLO_RETRY: Duration = Duration::from_millis(250);
/// How long a controller may take to answer its first `Hello`.
pub const HELLO_TIMEOUT: Duration = Duration::from_secs(20);
/// How long one response may take.
pub const RESPONSE_TIMEOUT: Duration = Duration::from_secs(10);
/// The serial port's speed, as the firmware sets its USART.
pub const BAUD: u32 = 115_200;

/// What went wrong on the link.
#[derive(Debug, thiserror::Error)]
pub enum StreamError {
    /// The port could not be opened or used.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: String,
        /// The cause.
        source: std::io::Error,
    },
    /// No answer in time.
    #[error("the controller did not answer {what} within {seconds} s")]
    Timeout {
        /// The request.
        what: &'static str,
        /// The time waited.
        seconds: u64,
    },
    /// An answer that does not fit the request.
    #[error("the controller answered {what} with {got}")]
    Unexpected {
        /// The request.
        what: &'static str,
        /// What came back.
        got: String,
    },
    /// The controller refused the calibration.
    #[error("the controller refused the calibration: {0}")]
    Refused(Rejection),
}

/// A byte stream to the controller: a TCP socket or a serial port, whose reads
/// time out after a short wait (so that the session can keep its own deadlines).
pub trait Port: Read + Write + Send {}

impl<T: Read + Write + Send> Port for T {}

/// Opens `HOST:PORT` over TCP, without Nagle's delay (one small frame each way per tick).
pub fn open_tcp(address: &str) -> Result<Box<dyn Port>, StreamError> {
    let io = |source| StreamError::Io {
        what: format!("cannot connect to {address}"),
        source,
    };
    let mut last = None;
    for addr in address.to_socket_addrs().map_err(io)? {
        match TcpStream::connect_timeout(&addr, Duration::from_secs(5)) {
            Ok(stream) => {
                stream.set_nodelay(true).map_err(io)?;
                stream
                    .set_read_timeout(Some(Duration::from_millis(50)))
                    .map_err(io)?;
                return Ok(Box::new(stream));
            }
            Err(e) => last = Some(e),
        }
    }
    Err(io(last.unwrap_or_else(|| {
        std::io::Error::new(ErrorKind::NotFound, "no address")
    })))
}

/// Opens the serial port at `path`: [`BAUD`] baud, 8 data bits, no parity, one stop bit.
pub fn open_serial(path: &str) -> Result<Box<dyn Port>, StreamError> {
    let port = serialport::new(path, BAUD)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(Duration::from_millis(50))
        .open()
        .map_err(|e| StreamError::Io {
            what: format!("cannot open the serial port {path}"),
            source: e.into(),
        })?;
    Ok(Box::new(port))
}

/// A session with the controller.
pub struct Session {
    port: Box<dyn Port>,
    frames: FrameBuffer,
    buf: [u8; 512],
    pos: usize,
    len: usize,
}

impl Session {
    /// Opens a session on `port` (the `Hello` exchange, see [the module](self)),
    /// with the controller's counters at that moment.
    pub fn open(port: Box<dyn Port>) -> Result<(Self, StatusReport), StreamError> {
        let mut s = Self {
            port,
            frames: FrameBuffer::new(),
            buf: [0; 512],
            pos: 0,
            len: 0,
        };
        let start = Instant::now();
        // A nonce of the clock, so that a session never takes an earlier one's answer.
        let mut nonce = start.elapsed().subsec_nanos() ^ std::process::id();
        while start.elapsed() < HELLO_TIMEOUT {
            nonce = nonce.wrapping_add(1);
            // A lone 0x00 first: it ends any partial frame on the line.
            s.write(&[0])?;
            s.send(&Request::Hello { nonce })?;
            let deadline = Instant::now() + HELLO_RETRY;
            while let Some(response) = s.receive(deadline)? {
                if let Response::Hello { nonce: n, status } = response
                    && n == nonce
                {
                    return Ok((s, status));
                }
            }
        }
        Err(StreamError::Timeout {
            what: "Hello",
            seconds: HELLO_TIMEOUT.as_secs(),
        })
    }

    fn write(&mut self, bytes: &[u8]) -> Result<(), StreamError> {
        self.port
            .write_all(bytes)
            .and_then(|()| self.port.flush())
            .map_err(|source| StreamError::Io {
                what: "cannot send to the controller".into(),
                source,
            })
    }

    fn send(&mut self, request: &Request) -> Result<(), StreamError> {
        let mut out = [0u8; MAX_FRAME];
        let frame = link::encode(request, &mut out).map_err(|e| StreamError::Io {
            what: "cannot encode a request".into(),
            source: std::io::Error::other(e.to_string()),
        })?;
        let frame = frame.to_vec();
        self.write(&frame)
    }

    /// The next response, or `None` at `deadline`. A frame that does not decode
    /// is an error: the link is not carrying this protocol.
    fn receive(&mut self, deadline: Instant) -> Result<Option<Response>, StreamError> {
        loop {
            while self.pos < self.len {
                let byte = self.buf[self.pos];
                self.pos += 1;
                if let Some(frame) = self.frames.push(byte) {
                    let response = frame.and_then(link::decode::<Response>).map_err(|e| {
                        StreamError::Unexpected {
                            what: "a request",
                            got: format!("a frame that is not a response ({e})"),
                        }
                    })?;
                    return Ok(Some(response));
                }
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            match self.port.read(&mut self.buf) {
                Ok(0) => {
                    return Err(StreamError::Io {
                        what: "the controller closed the link".into(),
                        source: ErrorKind::UnexpectedEof.into(),
                    });
                }
                Ok(n) => (self.pos, self.len) = (0, n),
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                    ) => {}
                Err(source) => {
                    return Err(StreamError::Io {
                        what: "cannot read from the controller".into(),
                        source,
                    });
                }
            }
        }
    }

    /// Sends `request` and waits for its response.
    pub fn request(
        &mut self,
        request: &Request,
        what: &'static str,
    ) -> Result<Response, StreamError> {
        self.send(request)?;
        self.receive(Instant::now() + RESPONSE_TIMEOUT)?
            .ok_or(StreamError::Timeout {
                what,
                seconds: RESPONSE_TIMEOUT.as_secs(),
            })
    }

    /// Sends a calibration file in chunks; the controller's verdict.
    pub fn load_calibration(&mut self, file: &[u8]) -> Result<Response, StreamError> {
        let total = u16::try_from(file.len()).unwrap_or(u16::MAX);
        let chunks: Vec<&[u8]> = file.chunks(CHUNK_LEN).collect();
        for (i, chunk) in chunks.iter().enumerate() {
            let request = Request::CalibrationChunk {
                total,
                offset: (i * CHUNK_LEN) as u16,
                bytes: chunk.iter().copied().collect(),
            };
            let response = self.request(&request, "a calibration chunk")?;
            match response {
                Response::ChunkReceived { .. } if i + 1 < chunks.len() => {}
                Response::CalibrationAccepted { .. } => return Ok(response),
                Response::CalibrationRejected { reason } => {
                    return Err(StreamError::Refused(reason));
                }
                other => {
                    return Err(StreamError::Unexpected {
                        what: "a calibration chunk",
                        got: format!("{other:?}"),
                    });
                }
            }
        }
        Err(StreamError::Unexpected {
            what: "the last calibration chunk",
            got: "no verdict".into(),
        })
    }

    /// The controller's counters.
    pub fn status(&mut self, request: Request) -> Result<StatusReport, StreamError> {
        match self.request(&request, "Status")? {
            Response::Status(s) => Ok(s),
            other => Err(StreamError::Unexpected {
                what: "Status",
                got: format!("{other:?}"),
            }),
        }
    }

    /// The ticks outside the identified ranges since the calibration was
    /// loaded; `None` from a controller that does not count them (it refuses
    /// the request as a frame it does not know).
    pub fn ranges(&mut self) -> Result<Option<RangeReport>, StreamError> {
        match self.request(&Request::Ranges, "Ranges")? {
            Response::Ranges(r) => Ok(Some(r)),
            Response::FrameRejected { .. } => Ok(None),
            other => Err(StreamError::Unexpected {
                what: "Ranges",
                got: format!("{other:?}"),
            }),
        }
    }

    /// One tick: the row's commands (SI) and context; the controller's answer.
    pub fn command(
        &mut self,
        seq: u32,
        q: &[f64],
        context: Option<Context>,
    ) -> Result<Corrected, StreamError> {
        let request = Request::Command(Command {
            seq,
            q: q.iter().map(|&v| v as f32).collect(),
            context,
        });
        match self.request(&request, "a command")? {
            Response::Corrected(c) if c.seq == seq => Ok(c),
            other => Err(StreamError::Unexpected {
                what: "a command",
                got: format!("{other:?}"),
            }),
        }
    }
}

/// The controller's answers to a joints file, row by row.
#[derive(Clone, Debug)]
pub struct Streamed {
    /// `(line, answer)` per input row.
    pub rows: Vec<(usize, Corrected)>,
    /// The nominal commands of each row, SI.
    pub commands: Vec<Vec<f64>>,
    /// The counters after the last row.
    pub status: StatusReport,
    /// The ticks outside the identified ranges, if the controller counts them.
    pub ranges: Option<RangeReport>,
}

/// Streams every row of `commands` (read against `cal`) through `session`.
pub fn stream_rows(session: &mut Session, commands: &JointRows) -> Result<Streamed, StreamError> {
    let mut rows = Vec::with_capacity(commands.rows.len());
    for (seq, row) in commands.rows.iter().enumerate() {
        let context = (row.temp.is_some() || row.load.is_some()).then(|| Context {
            temperature: row.temp.map(|t| t as f32),
            payload: row.load.map(|m| m as f32),
        });
        rows.push((row.line, session.command(seq as u32, &row.q, context)?));
    }
    let status = session.status(Request::Status)?;
    let ranges = session.ranges()?;
    Ok(Streamed {
        rows,
        commands: commands.rows.iter().map(|row| row.q.clone()).collect(),
        status,
        ranges,
    })
}

impl Streamed {
    /// The CSV `q1..qM` in the model's units, with a comment line naming its origin.
    pub fn to_csv(&self, cal: &Calibration, calibration_file: &str, link: &str) -> String {
        crate::apply::compensate::joints_csv(
            &format!(
                "armcal stream: commands corrected by the controller at {link} with {calibration_file}"
            ),
            cal,
            self.rows
                .iter()
                .map(|(_, c)| c.q.iter().map(|q| f64::from(*q)).collect()),
        )
    }

    /// What the controller said of the rows ([`compensate::RowWarning`]):
    /// each row whose status was not `Corrected`, in order, the rows of a
    /// position-only calibration whose point is reached with the flange
    /// turned by more than [`compensate::TURN`] (the turn the calibrated
    /// geometry gives between the nominal commands and the commands sent,
    /// [`Compensator::turn`]: with joint effects, their offsets besides, a
    /// fraction of a mrad), then the count of the rows whose pose is reached
    /// but whose least correction did not settle (told apart by the residual
    /// against the controller's tolerance), and the registration of `cal` the
    /// rows were asked to move by, when they were bounded
    /// ([`compensate::registration`]).
    pub fn warnings(&self, cal: &Calibration) -> Vec<compensate::RowWarning> {
        let tolerance = f64::from(Limits::<f32>::default().tolerance);
        let compensator = Compensator::<f64>::from_calibration(cal, Limits::default());
        let turned: Vec<(usize, f64)> = self
            .rows
            .iter()
            .zip(&self.commands)
            .filter(|((_, c), _)| {
                matches!(c.status, TickStatus::Corrected | TickStatus::NotConverged)
                    && f64::from(c.residual) <= tolerance
            })
            .filter_map(|((line, c), q_cmd)| {
                let sent: Vec<f64> = c.q.iter().map(|q| f64::from(*q)).collect();
                let turn = compensator.turn(q_cmd, &sent)?;
                (turn > compensate::TURN).then_some((*line, turn))
            })
            .collect();
        let mut settling = 0;
        let named: Vec<(usize, String)> = self
            .rows
            .iter()
            .filter(|(_, c)| !c.status.is_corrected())
            .filter_map(|(line, c)| {
                let what = match c.status {
                    TickStatus::Uncalibrated => "passed through: no calibration in force".into(),
                    TickStatus::NonFinite => {
                        "not computable (a value was not finite): nominal command kept".into()
                    }
                    TickStatus::JointCount => "wrong joint count: nominal command kept".into(),
                    TickStatus::NotConverged if f64::from(c.residual) <= tolerance => {
                        settling += 1;
                        return None;
                    }
                    TickStatus::NotConverged => compensate::missed(f64::from(c.residual)),
                    TickStatus::Limited => "correction bounded (size or change per tick)".into(),
                    TickStatus::Corrected => String::new(),
                };
                Some((*line, what))
            })
            .collect();
        compensate::RowWarning::of_rows(
            named.into_iter(),
            turned,
            settling,
            self.rows.len(),
            compensate::registration(cal),
        )
    }

    /// What the controller says of the ranges: the ticks outside and which
    /// values were, or why it says nothing.
    fn ranges_summary(&self) -> String {
        match self.ranges {
            None => "ticks outside the identified ranges not reported (the controller predates the count)".into(),
            Some(RangeReport { known: false, .. }) => {
                "ticks outside the identified ranges not judged (the calibration does not record them)".into()
            }
            Some(RangeReport {
                ticks_outside,
                outside,
                ..
            }) => outside_text(u64::from(ticks_outside), outside, "ticks"),
        }
    }

    /// The summary for standard error: rows, faults, deadline misses, stack,
    /// the ticks outside the identified ranges.
    pub fn summary(&self) -> String {
        let s = &self.status;
        let corrected = self
            .rows
            .iter()
            .filter(|(_, c)| c.status.is_corrected())
            .count();
        format!(
            "{} commands, {} corrected to tolerance; controller: {} ticks, {} faults, {} sequence gaps, {} deadline misses (worst tick {} cycles of {}), {} frame errors, stack used {} bytes, {}",
            self.rows.len(),
            corrected,
            s.ticks,
            s.faults,
            s.sequence_gaps,
            s.deadline_misses,
            s.worst_tick_cycles,
            s.tick_period_cycles,
            s.frame_errors,
            s.stack_used,
            self.ranges_summary()
        )
    }
}

/// `count` of `what` (ticks, cycles) outside the identified ranges, with the
/// values that were (`q2`, `temp`, `load`), as the controller and `armcal
/// serve` report them.
pub fn outside_text(count: u64, outside: Outside, what: &str) -> String {
    let mut which: Vec<String> = (0..16)
        .filter(|&m| outside.joint(m))
        .map(|m| format!("q{}", m + 1))
        .collect();
    if outside.temperature {
        which.push("temp".into());
    }
    if outside.load {
        which.push("load".into());
    }
    let which = if which.is_empty() {
        String::new()
    } else {
        format!(" ({})", which.join(", "))
    };
    format!("{count} {what} outside the identified ranges{which}")
}
