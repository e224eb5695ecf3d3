//! `armcal serve`: online compensation through the real-time sensor
//! interfaces industrial controllers already have, KUKA RSI ([`rsi`]) and
//! ABB EGM ([`egm`]), over UDP.
//!
//! The controller sends a datagram every cycle (4 ms by default) and expects
//! the answer within it. armcal answers each in the thread that received it:
//! decode, one [`cycle::Cycle`] (the same `Stream` the firmware and `armcal
//! compensate --servo` run, then the ramp of what is sent), encode, send.
//! Nothing else runs between a datagram and its answer: no allocation in
//! the stream, no lock, no I/O but the socket's.
//!
//! - **RSI**: each `<Rob>`'s set-point axes (`ASPos`, degrees) are
//!   corrected; the answer carries the correction `AK` (degrees) and the
//!   `IPOC` echoed, absolute (`AXISCORR` in `#ABSOLUTE` mode, the default) or
//!   each cycle's increment ([`RsiMode::Relative`]: the increments are of
//!   the values as printed, so that their sum is the correction to the
//!   printed precision, without drift).
//! - **EGM**: each `EgmRobot` is answered with an `EgmSensor` whose
//!   reference is the joint file's next row, corrected (degrees): the
//!   trajectory paced by the controller; after its last row the last
//!   reference is held.
//!
//! Faults, each counted ([`stats::Stats`]) and none ever sending a wild
//! command: a datagram that is not the protocol's message (damaged,
//! truncated, oversized, a DOCTYPE or entity, a protobuf field of the wrong
//! type, a value that is not a finite number, another axis count) is
//! answered with the held correction (RSI: when its IPOC can be read;
//! EGM: the last reference, once one was sent); a duplicated or reordered
//! one (its stamp not after the last corrected) likewise, the stream not
//! ticked; a correction whose change exceeds the step is ramped; a
//! set-point outside the identified ranges is corrected and counted. The
//! joint count of the first message must be the calibration's, or nothing is
//! answered and the run refused ([`ServeError::JointCount`]). After a stop
//! signal (Ctrl-C, SIGTERM) each cycle still sent is answered with the
//! correction ramping to none (EGM: at the reference of the row reached),
//! then the run ends; a controller silent for the timeout ends it too.
//!
//! Units on the wire: degrees (every joint revolute); SI inside.

pub mod cycle;
pub mod egm;
pub mod rsi;
pub mod stats;

use std::net::{SocketAddr, UdpSocket};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use armcal_shared::Calibration;
use armcal_shared::compensation::Conditions;

use cycle::Cycle;
use stats::Stats;

/// How long one receive call waits before the loop looks at the signals.
pub const POLL: Duration = Duration::from_millis(20);

/// What an RSI correction is: the `AXISCORR` object's mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RsiMode {
    /// The whole correction each cycle (`RSI_ON(#ABSOLUTE)`).
    Absolute,
    /// Each cycle's increment (`RSI_ON(#RELATIVE)`).
    Relative,
}

/// The interface served, and what it needs.
#[derive(Clone, Debug)]
pub enum Interface {
    /// KUKA RSI.
    Rsi {
        /// The correction's mode.
        mode: RsiMode,
        /// The `Type` of `<Sen>` (the ETHERNET object's `SENTYPE`).
        sen_type: String,
    },
    /// ABB EGM, streaming a trajectory.
    Egm {
        /// The joint file's rows: set-points (rad) and their conditions.
        rows: Vec<(Vec<f64>, Conditions<f64>)>,
    },
}

/// How a run is paced and bounded.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// The controller's cycle: an answer later than it is counted late.
    pub cycle: Duration,
    /// Silence after which the controller is taken to have stopped.
    pub timeout: Duration,
    /// The largest change of a joint's sent correction per cycle, rad.
    pub max_step: f64,
    /// The conditions of every set-point (RSI), or of the rows without
    /// their own (EGM).
    pub conditions: Conditions<f64>,
}

/// What the loop watches besides the socket: the stop signal's number (0:
/// none yet) and a request for the statistics.
#[derive(Debug, Default)]
pub struct Signals {
    /// Set to the signal's number by a SIGINT or SIGTERM handler.
    pub stop: Arc<AtomicUsize>,
    /// Set by a SIGUSR1 handler: print the statistics so far.
    pub report: Arc<AtomicBool>,
}

/// Why a run ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ending {
    /// No datagram for the timeout.
    Silent,
    /// A stop signal (its number); the correction had ramped to none, or
    /// no cycle was in flight.
    Interrupted(usize),
}

/// A run's end and its counts.
#[derive(Clone, Debug)]
pub struct Served {
    /// Why it ended.
    pub ending: Ending,
    /// What was counted.
    pub stats: Stats,
}

/// Why a run could not go on.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The socket failed.
    #[error("{what}: {source}")]
    Io {
        /// What was being done.
        what: &'static str,
        /// The cause.
        source: std::io::Error,
    },
    /// The first message's joint count is not the calibration's.
    #[error(
        "the controller sends {sent} axes ({what}) and the calibration has {calibration} joints: \
         nothing was answered"
    )]
    JointCount {
        /// Axes in the controller's first message.
        sent: usize,
        /// Where they were counted.
        what: &'static str,
        /// The calibration's joints.
        calibration: usize,
    },
}

/// What a protocol answers to one datagram.
trait Protocol {
    /// The answer to `datagram` (None: not answered), given the cycle's
    /// state; `stopping`: a stop signal came, the correction ramps to none.
    fn answer(
        &mut self,
        datagram: &[u8],
        stopping: bool,
        cycle: &mut Cycle,
        stats: &mut Stats,
    ) -> Result<Option<&[u8]>, ServeError>;

    /// Whether the correction sent has reached none (after a stop signal).
    fn settled(&self, cycle: &Cycle) -> bool;

    /// Whether a first good message was answered.
    fn started(&self) -> bool;
}

/// Serves `interface` on `socket` for `cal` until the controller is silent
/// for the timeout or a stop signal's ramp has ended (see [the
/// module](self)); `report` prints the statistics on request.
pub fn serve(
    socket: &UdpSocket,
    cal: &Calibration,
    interface: Interface,
    options: &Options,
    signals: &Signals,
    report: &mut dyn FnMut(&Stats),
) -> Result<Served, ServeError> {
    let io = |what| move |source| ServeError::Io { what, source };
    socket
        .set_read_timeout(Some(POLL))
        .map_err(io("setting the socket's timeout"))?;
    let mut cycle = Cycle::new(cal, options.max_step);
    let mut stats = Stats {
        ranges_known: cycle.ranges_known(),
        ..Stats::default()
    };
    let mut protocol: Box<dyn Protocol> = match interface {
        Interface::Rsi { mode, sen_type } => Box::new(RsiServer::new(
            mode,
            sen_type,
            cycle.dof(),
            options.conditions,
        )),
        Interface::Egm { rows } => Box::new(EgmServer::new(rows, options.conditions)),
    };
    let mut buf = vec![0u8; rsi::MAX_DATAGRAM.max(egm::MAX_DATAGRAM) + 1];
    let mut last: Option<Instant> = None;
    let mut stopping = None;
    loop {
        let signal = signals.stop.load(Ordering::Relaxed);
        if stopping.is_none() && signal != 0 {
            stopping = Some(signal);
            if !protocol.started() {
                return Ok(Served {
                    ending: Ending::Interrupted(signal),
                    stats,
                });
            }
        }
        if signals.report.swap(false, Ordering::Relaxed) {
            report(&stats);
        }
        let (n, from): (usize, SocketAddr) = match socket.recv_from(&mut buf) {
            Ok(received) => received,
            // A timeout, or a signal that interrupted the call (its flag
            // is read at the loop's top).
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                if last.is_some_and(|t| t.elapsed() >= options.timeout) {
                    return Ok(Served {
                        ending: match stopping {
                            Some(signal) => Ending::Interrupted(signal),
                            None => Ending::Silent,
                        },
                        stats,
                    });
                }
                continue;
            }
            // An ICMP "port unreachable" of an earlier answer (Linux reports
            // it on the next receive): the controller went away; wait on.
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => continue,
            Err(source) => {
                return Err(ServeError::Io {
                    what: "receiving",
                    source,
                });
            }
        };
        let arrived = Instant::now();
        last = Some(arrived);
        let answer = protocol.answer(&buf[..n], stopping.is_some(), &mut cycle, &mut stats)?;
        if let Some(bytes) = answer {
            let sent = loop {
                match socket.send_to(bytes, from) {
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                    sent => break sent,
                }
            };
            match sent {
                Ok(_) => {}
                Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => {}
                Err(source) => {
                    return Err(ServeError::Io {
                        what: "answering",
                        source,
                    });
                }
            }
            let took = arrived.elapsed();
            stats.latency.record(took);
            stats.late += u64::from(took > options.cycle);
        }
        if let Some(signal) = stopping
            && protocol.settled(&cycle)
        {
            return Ok(Served {
                ending: Ending::Interrupted(signal),
                stats,
            });
        }
    }
}

/// The RSI side: see [`rsi`].
struct RsiServer {
    mode: RsiMode,
    sen_type: String,
    /// The conditions of every set-point.
    conditions: Conditions<f64>,
    started: bool,
    last_ipoc: Option<u64>,
    /// Relative mode: the sum of the increments sent, as printed, degrees.
    sent: Vec<f64>,
    /// The correction of this answer, degrees.
    ak: Vec<f64>,
    text: String,
}

impl RsiServer {
    fn new(mode: RsiMode, sen_type: String, dof: usize, conditions: Conditions<f64>) -> Self {
        Self {
            mode,
            sen_type,
            conditions,
            started: false,
            last_ipoc: None,
            sent: vec![0.0; dof],
            ak: vec![0.0; dof],
            text: String::new(),
        }
    }

    /// The answer with the held correction: absolute, the last sent;
    /// relative, no increment.
    fn held(&mut self, cycle: &Cycle, ipoc: u64) -> &[u8] {
        match self.mode {
            RsiMode::Absolute => {
                for (ak, x) in self.ak.iter_mut().zip(cycle.offset()) {
                    *ak = x.to_degrees();
                }
            }
            RsiMode::Relative => self.ak.iter_mut().for_each(|ak| *ak = 0.0),
        }
        rsi::write_sen(&mut self.text, &self.sen_type, &self.ak, ipoc);
        self.text.as_bytes()
    }

    /// The answer with the correction just computed.
    fn corrected(&mut self, cycle: &Cycle, ipoc: u64) -> &[u8] {
        for ((ak, sent), x) in self.ak.iter_mut().zip(&mut self.sent).zip(cycle.offset()) {
            let deg = x.to_degrees();
            *ak = match self.mode {
                RsiMode::Absolute => deg,
                RsiMode::Relative => {
                    // The increment as printed, so that the printed
                    // increments sum to the correction.
                    let printed: f64 = format!("{:.*}", rsi::DECIMALS, deg - *sent)
                        .parse()
                        .unwrap_or(0.0);
                    *sent += printed;
                    printed
                }
            };
        }
        rsi::write_sen(&mut self.text, &self.sen_type, &self.ak, ipoc);
        self.text.as_bytes()
    }
}

impl Protocol for RsiServer {
    fn answer(
        &mut self,
        datagram: &[u8],
        stopping: bool,
        cycle: &mut Cycle,
        stats: &mut Stats,
    ) -> Result<Option<&[u8]>, ServeError> {
        let rob = match rsi::parse(datagram) {
            Ok(rob) if rob.aspos.len() == cycle.dof() => rob,
            Ok(rob) if !self.started => {
                return Err(ServeError::JointCount {
                    sent: rob.aspos.len(),
                    what: "ASPos A1..An",
                    calibration: cycle.dof(),
                });
            }
            refused => {
                let ipoc = rsi::scan_ipoc(datagram);
                stats.refused(refused == Err(rsi::RobError::Oversized), ipoc.is_some());
                return Ok(ipoc.map(|ipoc| self.held(cycle, ipoc)));
            }
        };
        stats.controller_delay = rob.delay.or(stats.controller_delay);
        if self.last_ipoc.is_some_and(|last| rob.ipoc <= last) {
            stats.repeated += 1;
            return Ok(Some(self.held(cycle, rob.ipoc)));
        }
        self.last_ipoc = Some(rob.ipoc);
        self.started = true;
        let q: Vec<f64> = rob.aspos.iter().map(|d| d.to_radians()).collect();
        let step = cycle.next((!stopping).then_some((&q[..], &self.conditions)));
        stats.corrected(&step, cycle.offset());
        Ok(Some(self.corrected(cycle, rob.ipoc)))
    }

    fn settled(&self, cycle: &Cycle) -> bool {
        cycle.is_zero()
            && (self.mode == RsiMode::Absolute || self.sent.iter().all(|s| s.abs() < 0.5e-6))
    }

    fn started(&self) -> bool {
        self.started
    }
}

/// The EGM side: see [`egm`].
struct EgmServer {
    rows: Vec<(Vec<f64>, Conditions<f64>)>,
    defaults: Conditions<f64>,
    /// The row of the next new cycle.
    next: usize,
    last_seqno: Option<u32>,
    /// The sensor's own sequence number.
    seqno: u32,
    since: Instant,
    /// The reference of the last answer, degrees (none before the first).
    reference: Option<Vec<f64>>,
    bytes: Vec<u8>,
}

impl EgmServer {
    fn new(rows: Vec<(Vec<f64>, Conditions<f64>)>, defaults: Conditions<f64>) -> Self {
        Self {
            rows,
            defaults,
            next: 0,
            last_seqno: None,
            seqno: 0,
            since: Instant::now(),
            reference: None,
            bytes: Vec::new(),
        }
    }

    /// Encodes the answer with the reference held.
    fn send(&mut self) -> Option<&[u8]> {
        let reference = self.reference.as_ref()?;
        let tm = u32::try_from(self.since.elapsed().as_millis()).unwrap_or(u32::MAX);
        egm::write_sensor(&mut self.bytes, self.seqno, tm, reference);
        self.seqno = self.seqno.wrapping_add(1);
        Some(&self.bytes)
    }
}

impl Protocol for EgmServer {
    fn answer(
        &mut self,
        datagram: &[u8],
        stopping: bool,
        cycle: &mut Cycle,
        stats: &mut Stats,
    ) -> Result<Option<&[u8]>, ServeError> {
        let robot = match egm::parse(datagram) {
            Ok(robot) if robot.joints == Some(cycle.dof()) => robot,
            Ok(egm::Robot {
                joints: Some(sent), ..
            }) if self.reference.is_none() => {
                return Err(ServeError::JointCount {
                    sent,
                    what: "feedBack.joints",
                    calibration: cycle.dof(),
                });
            }
            refused => {
                let oversized = refused == Err(egm::RobotError::Oversized);
                stats.refused(oversized, self.reference.is_some());
                return Ok(self.send());
            }
        };
        if let (Some(s), Some(last)) = (robot.seqno, self.last_seqno)
            && (s.wrapping_sub(last) as i32) <= 0
        {
            stats.repeated += 1;
            return Ok(self.send());
        }
        self.last_seqno = robot.seqno.or(self.last_seqno);
        let row = if stopping {
            self.next.saturating_sub(1)
        } else if self.next < self.rows.len() {
            self.next += 1;
            self.next - 1
        } else {
            stats.held_at_end += 1;
            self.rows.len().saturating_sub(1)
        };
        let Some((q, conditions)) = self.rows.get(row) else {
            return Ok(None);
        };
        let conditions = Conditions {
            temperature: conditions.temperature.or(self.defaults.temperature),
            payload: conditions.payload.or(self.defaults.payload),
        };
        let step = cycle.next((!stopping).then_some((&q[..], &conditions)));
        stats.corrected(&step, cycle.offset());
        let reference = q
            .iter()
            .zip(cycle.offset())
            .map(|(q, x)| (q + x).to_degrees())
            .collect();
        self.reference = Some(reference);
        Ok(self.send())
    }

    fn settled(&self, cycle: &Cycle) -> bool {
        cycle.is_zero()
    }

    fn started(&self) -> bool {
        self.reference.is_some()
    }
}
