//! The UDP side: [`MvnReceiver`] takes MVN's stream and keeps only the newest complete frame,
//! counting what it drops and why; [`MvnSender`] sends poses as MVN does (`sgplvm replay --as
//! mvn`).
//!
//! The receiver is a non-blocking `mio` UDP socket and a [`mio::event::Source`]: the node
//! registers it with its own `Poll` (as it registers its DDS subscription) and, on every
//! wake-up, calls [`MvnReceiver::newest`], which reads every waiting datagram (mio is
//! edge-triggered: a wake-up is only promised for datagrams arriving after a drain) and returns
//! the newest complete frame, if one arrived since the last call.
//!
//! **Who may drive.** A bound UDP port takes datagrams from anyone who can reach it. The
//! receiver takes pose datagrams from one sender ([`Senders`]): the one named (a host, or a
//! host and port), or by default the host of the first datagram that decodes as MVN pose data,
//! locked for the receiver's life (any of its ports: MVN restarted sends from another). Every other sender's datagrams are counted
//! ([`ReceiverCounts::other_sender`]) and dropped before they are decoded; the first few such
//! addresses are kept for the report ([`MvnReceiver::refused`]). This is not authentication (a
//! sender's address can be forged on a network that lets it be): it keeps a second stream, a
//! replay left running or a stray tool from moving the robot.
//!
//! **Units.** The first frame of each pose type that holds the spine, arms and legs decides
//! whether its positions are metres or centimetres ([`units`](super::units)); later frames are
//! scaled alike.

use std::collections::BTreeMap;
use std::io;
use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr, UdpSocket as StdUdpSocket};

use mio::event::Source;
use mio::net::UdpSocket;
use mio::{Interest, Registry, Token};

use super::assemble::{age, Age, Reassembler};
use super::datagram::{decode_part, encode, Header, MvnPose, PoseType};
use super::units::{body_span, Units};
use super::MvnError;

/// How many refused senders' addresses are kept for the report.
const REFUSED_KEPT: usize = 8;

/// Whose datagrams the receiver takes (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Senders {
    /// The host of the first datagram that decodes as MVN pose data, locked from then on (any
    /// of its ports).
    #[default]
    First,
    /// Any port of this host.
    Host(IpAddr),
    /// This address and port only.
    Address(SocketAddr),
}

impl Senders {
    /// `IP` (any port of that host) or `IP:PORT` (IPv6 as `[::1]:9763`), as `--mvn-from` takes.
    pub fn parse(s: &str) -> Result<Senders, String> {
        if let Ok(a) = s.parse::<SocketAddr>() {
            return Ok(Senders::Address(a));
        }
        s.parse::<IpAddr>().map(Senders::Host).map_err(|_| {
            format!("`{s}`: expected the sender's IP address, or IP:PORT (e.g. 192.168.1.20 or 192.168.1.20:50112)")
        })
    }
}

impl std::fmt::Display for Senders {
    /// `the first sender`, `192.168.1.20 (any port)`, `192.168.1.20:50112`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Senders::First => write!(f, "the first sender"),
            Senders::Host(ip) => write!(f, "{ip} (any port)"),
            Senders::Address(a) => write!(f, "{a}"),
        }
    }
}

/// Bytes a UDP datagram can hold (65,507 over IPv4), rounded up.
const BUFFER_BYTES: usize = 65_536;

/// Which datagrams the receiver takes; by default character 0's, both pose types.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReceiverOptions {
    /// The character to follow (§2.4.1.6; 0 in a one-person setup). Other characters' datagrams
    /// are counted and dropped.
    pub character: u8,
    /// The pose type to take, or `None` for both 01 and 02 (when MVN is set to stream both, the
    /// second of a sample is then counted as late).
    pub kind: Option<PoseType>,
    /// Whose datagrams are taken (default: the first sender's, locked).
    pub from: Senders,
}

/// What the receiver did with the datagrams it read.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ReceiverCounts {
    /// Datagrams read.
    pub datagrams: u64,
    /// Complete frames returned by [`MvnReceiver::newest`].
    pub frames: u64,
    /// Complete frames dropped because a newer one arrived in the same read.
    pub superseded: u64,
    /// Frames (or parts) of a sample no newer than one already returned or being assembled.
    pub late: u64,
    /// Split frames given up incomplete when a newer sample started.
    pub incomplete: u64,
    /// Times the sample counter went back further than [`LATE_WINDOW`](super::assemble::LATE_WINDOW)
    /// and was taken as the sender starting again.
    pub restarts: u64,
    /// Datagrams of another character.
    pub other_character: u64,
    /// Pose datagrams of the type not asked for.
    pub other_kind: u64,
    /// Datagrams from a sender not taken ([`Senders`]), dropped unread.
    pub other_sender: u64,
    /// Datagrams that could not be used, by [`MvnError::kind`].
    pub bad: BTreeMap<&'static str, u64>,
}

impl ReceiverCounts {
    /// Datagrams and frames dropped for any reason.
    pub fn dropped(&self) -> u64 {
        self.superseded
            + self.late
            + self.incomplete
            + self.other_character
            + self.other_kind
            + self.other_sender
            + self.bad.values().sum::<u64>()
    }
}

/// MVN's stream in: a bound UDP socket that keeps the newest complete frame.
#[derive(Debug)]
pub struct MvnReceiver {
    socket: UdpSocket,
    buf: Vec<u8>,
    assembler: Reassembler,
    options: ReceiverOptions,
    counts: ReceiverCounts,
    /// The sample counter of the last frame returned.
    last: Option<u32>,
    last_bad: Option<MvnError>,
    /// The sender taken (with [`Senders::First`], locked once seen).
    sender: Option<SocketAddr>,
    /// The first few senders refused.
    refused: Vec<SocketAddr>,
    /// Per pose type (01, 02), the units decided and the body span they were read from
    /// (metres).
    units: [Option<(Units, f64)>; 2],
}

impl MvnReceiver {
    /// Binds `addr` (MVN's default is `0.0.0.0:9763`; port 0 picks a free one).
    pub fn bind(addr: SocketAddr, options: ReceiverOptions) -> Result<MvnReceiver, MvnError> {
        let socket = UdpSocket::bind(addr).map_err(|source| MvnError::Socket {
            action: "binding",
            addr: addr.to_string(),
            source,
        })?;
        Ok(MvnReceiver {
            socket,
            buf: vec![0; BUFFER_BYTES],
            assembler: Reassembler::new(),
            options,
            counts: ReceiverCounts::default(),
            last: None,
            last_bad: None,
            sender: match options.from {
                Senders::Address(a) => Some(a),
                _ => None,
            },
            refused: Vec::new(),
            units: [None; 2],
        })
    }

    /// The sender of the last datagram taken (with [`Senders::First`] the host locked, with
    /// [`Senders::Address`] the one named); `None` before one was taken.
    pub fn sender(&self) -> Option<SocketAddr> {
        self.sender
    }

    /// The first few senders whose datagrams were refused (all are counted in
    /// [`ReceiverCounts::other_sender`]).
    pub fn refused(&self) -> &[SocketAddr] {
        &self.refused
    }

    /// The units of `kind`'s positions as the stream's person says, with the body span they
    /// were read from (metres, [`body_span`]); `None` until a frame told (the positions are
    /// then taken as decoded: type 02 metres, 01 centimetres).
    pub fn units(&self, kind: PoseType) -> Option<(Units, f64)> {
        self.units[kind_index(kind)]
    }

    /// The address bound (the port chosen when bound to port 0).
    pub fn local_addr(&self) -> Result<SocketAddr, MvnError> {
        self.socket.local_addr().map_err(|source| MvnError::Socket {
            action: "reading the address of",
            addr: "the receiver".into(),
            source,
        })
    }

    /// The options it was bound with.
    pub fn options(&self) -> &ReceiverOptions {
        &self.options
    }

    /// What it did so far.
    pub fn counts(&self) -> &ReceiverCounts {
        &self.counts
    }

    /// Why the last unusable datagram was dropped (for a log line).
    pub fn last_bad(&self) -> Option<&MvnError> {
        self.last_bad.as_ref()
    }

    /// Reads every waiting datagram without blocking and returns the newest complete frame that
    /// is newer than the last one returned, or `None`. Older frames are counted, not kept.
    /// Fails only when the socket does (not for a bad datagram, which is counted).
    pub fn newest(&mut self) -> Result<Option<MvnPose>, MvnError> {
        let mut buf = std::mem::take(&mut self.buf);
        let mut newest = None;
        let result = loop {
            match self.socket.recv_from(&mut buf) {
                Ok((n, from)) => self.take(&buf[..n], from, &mut newest),
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => break Ok(()),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(source) => {
                    break Err(MvnError::Socket {
                        action: "receiving on",
                        addr: self
                            .socket
                            .local_addr()
                            .map_or_else(|_| "the receiver".into(), |a| a.to_string()),
                        source,
                    })
                }
            }
        };
        self.buf = buf;
        result?;
        if let Some(frame) = newest.as_mut() {
            self.last = Some(frame.sample_counter);
            self.counts.frames += 1;
            let units = &mut self.units[kind_index(frame.kind)];
            if units.is_none() {
                *units = body_span(frame).and_then(|span| {
                    Units::of_span(span).map(|u| (u, span * f64::from(u.scale())))
                });
            }
            if let Some((u, _)) = units {
                u.apply(frame);
            }
        }
        Ok(newest)
    }

    /// Whether datagrams from `from` are taken (counted and kept for the report when not).
    /// With [`Senders::First`] before any is locked, every datagram is read: the first that
    /// decodes as pose data locks its sender's host ([`MvnReceiver::take`]).
    fn accepts(&mut self, from: SocketAddr) -> bool {
        let taken = match (self.options.from, self.sender) {
            (Senders::Address(a), _) => a == from,
            (Senders::Host(ip), _) => ip == from.ip(),
            (Senders::First, Some(s)) => s.ip() == from.ip(),
            (Senders::First, None) => true,
        };
        if !taken {
            self.counts.other_sender += 1;
            if self.refused.len() < REFUSED_KEPT && !self.refused.contains(&from) {
                self.refused.push(from);
            }
        }
        taken
    }

    /// One datagram from `from`: decoded, assembled, and kept in `newest` if it completes a
    /// newer frame.
    fn take(&mut self, bytes: &[u8], from: SocketAddr, newest: &mut Option<MvnPose>) {
        self.counts.datagrams += 1;
        if !self.accepts(from) {
            return;
        }
        let part = match Header::read(bytes) {
            Ok(h) if h.character_id != self.options.character => {
                self.counts.other_character += 1;
                return;
            }
            Ok(_) => decode_part(bytes),
            Err(e) => Err(e),
        };
        let part = match part {
            Ok(p) if self.options.kind.is_some_and(|k| k != p.pose.kind) => {
                self.counts.other_kind += 1;
                return;
            }
            Ok(p) => p,
            Err(e) => return self.bad(e),
        };
        self.sender = Some(from);
        let pushed = match self.assembler.push(part) {
            Ok(p) => p,
            Err(e) => return self.bad(e),
        };
        self.counts.incomplete += u64::from(pushed.abandoned);
        self.counts.late += u64::from(pushed.late);
        let Some(frame) = pushed.complete else {
            return;
        };
        let reference = newest.as_ref().map(|f| f.sample_counter).or(self.last);
        if let Some(reference) = reference {
            match age(frame.sample_counter, reference) {
                Age::Same | Age::Late => {
                    self.counts.late += 1;
                    return;
                }
                Age::Restart => self.counts.restarts += 1,
                Age::Newer => {}
            }
        }
        if newest.replace(frame).is_some() {
            self.counts.superseded += 1;
        }
    }

    /// Counts a dropped datagram by kind and keeps its error.
    fn bad(&mut self, e: MvnError) {
        *self.counts.bad.entry(e.kind()).or_default() += 1;
        self.last_bad = Some(e);
    }
}

/// The index of `kind` in per-type arrays.
fn kind_index(kind: PoseType) -> usize {
    match kind {
        PoseType::Euler => 0,
        PoseType::Quaternion => 1,
    }
}

impl Source for MvnReceiver {
    fn register(
        &mut self,
        registry: &Registry,
        token: Token,
        interests: Interest,
    ) -> io::Result<()> {
        self.socket.register(registry, token, interests)
    }

    fn reregister(
        &mut self,
        registry: &Registry,
        token: Token,
        interests: Interest,
    ) -> io::Result<()> {
        self.socket.reregister(registry, token, interests)
    }

    fn deregister(&mut self, registry: &Registry) -> io::Result<()> {
        self.socket.deregister(registry)
    }
}

/// Poses out as MVN sends them: one datagram per frame to one address.
#[derive(Debug)]
pub struct MvnSender {
    socket: StdUdpSocket,
    to: SocketAddr,
}

impl MvnSender {
    /// A sender to `to` from a free port (on loopback when `to` is a loopback address, else on
    /// every interface).
    pub fn new(to: SocketAddr) -> Result<MvnSender, MvnError> {
        let ip = match (to.ip().is_loopback(), to) {
            (true, _) => to.ip(),
            (false, SocketAddr::V4(_)) => IpAddr::V4(Ipv4Addr::UNSPECIFIED),
            (false, SocketAddr::V6(_)) => IpAddr::V6(Ipv6Addr::UNSPECIFIED),
        };
        let from = SocketAddr::new(ip, 0);
        let socket = StdUdpSocket::bind(from).map_err(|source| MvnError::Socket {
            action: "binding",
            addr: from.to_string(),
            source,
        })?;
        Ok(MvnSender { socket, to })
    }

    /// Where it sends.
    pub fn target(&self) -> SocketAddr {
        self.to
    }

    /// Sends `pose` as one datagram of type `kind` ([`encode`]).
    pub fn send(&self, pose: &MvnPose, kind: PoseType) -> Result<(), MvnError> {
        self.send_datagram(&encode(pose, kind)?)
    }

    /// Sends `datagram` as it is.
    pub fn send_datagram(&self, datagram: &[u8]) -> Result<(), MvnError> {
        self.socket
            .send_to(datagram, self.to)
            .map(|_| ())
            .map_err(|source| MvnError::Socket {
                action: "sending to",
                addr: self.to.to_string(),
                source,
            })
    }
}
