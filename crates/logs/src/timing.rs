//! Timestamps that cannot be trusted, and the file's order in their place.
//!
//! A reader stamps each message with the time the file gives it. Some files give times that
//! cannot order their messages: a CARMEN log printed with `%g` carries `1.13486e+09` on every line
//! of a 20-minute drive (one printed step is 10,000 s); a driver that stamps with a frozen clock
//! repeats one stamp; a converter that lost the clock writes times that go back and forth.
//! Sorted by such stamps, scans and odometry fall apart (every odometry reading before every
//! scan), and every estimator downstream fails without a word.
//!
//! [`StreamStamps`] says, per stream, whether its stamps can order its messages: not when more
//! than [`MAX_BAD_SHARE`] of consecutive stamps repeat or step back (and at least
//! [`MIN_BAD_PAIRS`] do), nor when the printed step is at least twice the mean spacing of the
//! messages (consecutive messages would share their printed time). [`by_order`] then times the
//! messages in the file's order (a CARMEN log is written in time order): from the printed stamps
//! where they change, or from a scan rate the user gives.

use std::fmt::Write as _;

/// More than this share of consecutive stamps repeating or stepping back makes a stream's stamps
/// untrusted.
pub const MAX_BAD_SHARE: f64 = 0.1;
/// ... and at least this many (two or three clamped steps back in a short log stay clamped, as
/// always).
pub const MIN_BAD_PAIRS: usize = 3;
/// The longest a log timed by its order may last, nanoseconds (about 116 days): printed stamps
/// that imply more (a first stamp of 0 before `1.13486e+09`s) cannot time its lines.
pub const MAX_SPAN_NS: f64 = 1e16;

/// What one stream's stamps show, in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct StreamStamps {
    /// The stream (a topic, a CARMEN message name).
    pub name: String,
    /// Its messages.
    pub messages: usize,
    /// Consecutive stamps that are equal.
    pub repeats: usize,
    /// Consecutive stamps that step back.
    pub backward: usize,
    /// The printed step of the stamps (the median of the messages'), nanoseconds; 0 when exact
    /// (a bag's integer nanoseconds).
    pub quantum_ns: u64,
    /// The mean spacing of the messages by their stamps (the span of the running maximum over
    /// the messages), nanoseconds.
    pub mean_spacing_ns: f64,
    /// Where the first repeat or step back is (`line 12`).
    pub first_bad: Option<String>,
}

impl StreamStamps {
    /// The stamps of stream `name` in file order, their printed steps (empty: exact) and a
    /// function naming the place of message `i`.
    pub fn of(name: &str, stamps: &[u64], quanta_ns: &[u64], place: impl Fn(usize) -> String) -> Self {
        let (mut repeats, mut backward, mut first_bad) = (0, 0, None);
        for i in 1..stamps.len() {
            let bad = match stamps[i].cmp(&stamps[i - 1]) {
                std::cmp::Ordering::Equal => {
                    repeats += 1;
                    true
                }
                std::cmp::Ordering::Less => {
                    backward += 1;
                    true
                }
                std::cmp::Ordering::Greater => false,
            };
            if bad && first_bad.is_none() {
                first_bad = Some(place(i));
            }
        }
        let quantum_ns = median(quanta_ns);
        let span = match (stamps.first(), stamps.iter().max()) {
            (Some(&first), Some(&max)) => (max - first) as f64,
            _ => 0.0,
        };
        let mean_spacing_ns = if stamps.len() > 1 { span / (stamps.len() - 1) as f64 } else { f64::INFINITY };
        Self {
            name: name.to_string(),
            messages: stamps.len(),
            repeats,
            backward,
            quantum_ns,
            mean_spacing_ns,
            first_bad,
        }
    }

    /// Whether the printed step is too coarse to order the messages.
    pub fn coarse(&self) -> bool {
        self.messages >= 3 && self.quantum_ns > 0 && self.quantum_ns as f64 >= 2.0 * self.mean_spacing_ns
    }

    /// Why this stream's stamps cannot order its messages; `None` when they can.
    pub fn distrust(&self) -> Option<String> {
        let pairs = self.messages.saturating_sub(1);
        let bad = self.repeats + self.backward;
        let many = bad >= MIN_BAD_PAIRS && bad as f64 > MAX_BAD_SHARE * pairs as f64;
        if !many && !self.coarse() {
            return None;
        }
        let mut why = format!("{}: ", self.name);
        if many {
            let _ = write!(
                why,
                "{} of {pairs} consecutive stamps repeat and {} step back (first at {})",
                self.repeats,
                self.backward,
                self.first_bad.as_deref().unwrap_or("?")
            );
        }
        if self.coarse() {
            let sep = if many { "; " } else { "" };
            let step = seconds(self.quantum_ns as f64);
            let _ = if self.mean_spacing_ns > 0.0 {
                write!(
                    why,
                    "{sep}stamps printed to {step} s, coarser than the messages' mean spacing of {} s",
                    seconds(self.mean_spacing_ns)
                )
            } else {
                write!(why, "{sep}stamps printed to {step} s: every message has the same printed time")
            };
        }
        Some(why)
    }
}

/// The median of `values` (the upper one of an even count; 0 when empty).
pub fn median(values: &[u64]) -> u64 {
    let mut v = values.to_vec();
    v.sort_unstable();
    v.get(v.len() / 2).copied().unwrap_or(0)
}

/// Where the time moves on: each message (index, stamp) whose stamp is above every stamp before
/// it, the first message not counted.
pub fn changes(stamps: &[u64]) -> Vec<(usize, u64)> {
    let mut out = Vec::new();
    let Some(&first) = stamps.first() else { return out };
    let mut high = first;
    for (i, &s) in stamps.iter().enumerate().skip(1) {
        if s > high {
            high = s;
            out.push((i, s));
        }
    }
    out
}

/// Seconds, briefly: `10000`, `0.01`, `2.91`.
fn seconds(ns: f64) -> String {
    let s = ns * 1e-9;
    if !s.is_finite() {
        "∞".into()
    } else if s >= 100.0 {
        format!("{s:.0}")
    } else {
        format!("{:.3}", s).trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// The printed step of a decimal number as written (`1.13486e+09` → 1e4 s, `0.204947` → 1e-6 s,
/// `12` → 1 s), nanoseconds, at least 1.
pub fn printed_quantum_ns(text: &str) -> u64 {
    let (mantissa, exponent) = match text.find(['e', 'E']) {
        // An exponent past ±400 prints a value that is 0 or not finite anyway.
        Some(i) => (&text[..i], text[i + 1..].parse::<i32>().unwrap_or(0).clamp(-400, 400)),
        None => (text, 0),
    };
    let decimals = i32::try_from(mantissa.find('.').map_or(0, |dot| mantissa.len() - dot - 1)).unwrap_or(i32::MAX);
    let q = 10f64.powi(exponent.saturating_sub(decimals)) * 1e9;
    if q.is_finite() { q.max(1.0).min(u64::MAX as f64) as u64 } else { u64::MAX }
}

/// How [`by_order`] spaced the messages.
#[derive(Clone, Debug, PartialEq)]
pub enum Spacing {
    /// From the printed stamps: linear in the file's order between the messages where the
    /// printed time changes (`anchors` of them).
    Printed {
        /// The messages where the printed time changes that anchor the times.
        anchors: usize,
    },
    /// From the scan rate given (`--rate`).
    Rate(f64),
}

/// Times for messages whose stamps cannot order them, in the file's order.
///
/// `stamps`: every timed message in file order (nanoseconds as printed); `quantum_ns`: their
/// printed step; `scans`: the indices (into `stamps`, increasing) of the first lidar's scans;
/// `rate_hz`: that lidar's scan rate if the user gave it. With a rate, the first lidar's scan
/// `k` is at `k / rate` and the messages between two scans are spaced evenly between them. Without
/// one, the printed stamps anchor the times where they change (a change of a coarse stamp is the
/// moment the true time crossed a printed step; a fine stamp anchors every message whose stamp
/// moved on) and the messages between anchors are spaced evenly; before the first anchor and
/// after the last, the mean spacing between anchors continues. The times are strictly increasing
/// and start at the first printed stamp.
///
/// `Err` (with the index of the message where the time is lost) when neither gives a spacing:
/// no rate and fewer than two anchors, or times that would span more than [`MAX_SPAN_NS`].
pub fn by_order(
    stamps: &[u64],
    quantum_ns: u64,
    scans: &[usize],
    rate_hz: Option<f64>,
) -> Result<(Vec<u64>, Spacing), usize> {
    let n = stamps.len();
    if n == 0 {
        return Ok((Vec::new(), Spacing::Printed { anchors: 0 }));
    }
    let (anchors, spacing): (Vec<(usize, f64)>, Spacing) = match rate_hz {
        Some(rate) => {
            let a: Vec<(usize, f64)> = scans.iter().enumerate().map(|(k, &i)| (i, k as f64 / rate * 1e9)).collect();
            if a.len() < 2 {
                // One scan: the rate spaces the other messages one scan period apart each.
                let i0 = a.first().map_or(0, |p| p.0);
                (vec![(i0, 0.0), (i0 + 1, 1e9 / rate)], Spacing::Rate(rate))
            } else {
                (a, Spacing::Rate(rate))
            }
        }
        None => {
            let changes: Vec<(usize, f64)> =
                changes(stamps).into_iter().map(|(i, s)| (i, (s - stamps[0]) as f64)).collect();
            // The spacing per line the printed changes show: between the first and the last
            // change where there are two (a first stamp far from the rest, such as a 0 before
            // epoch times, does not count), else from the first line to the one change.
            let spacing = match (changes.first(), changes.last()) {
                (Some(a), Some(b)) if b.0 > a.0 => (b.1 - a.1) / (b.0 - a.0) as f64,
                (Some(a), _) => a.1 / a.0 as f64,
                _ => 0.0,
            };
            let coarse = quantum_ns as f64 >= 2.0 * spacing;
            // A fine stamp is a time where it is printed; a coarse one only where it changes.
            let mut a = if coarse { Vec::new() } else { vec![(0, 0.0)] };
            a.extend(changes);
            if a.len() < 2 {
                return Err(a.first().map_or(0, |p| p.0));
            }
            let k = a.len();
            (a, Spacing::Printed { anchors: k })
        }
    };
    let (first, last) = (anchors[0], anchors[anchors.len() - 1]);
    let mean = (last.1 - first.1) / (last.0 - first.0) as f64;
    let mut times = Vec::with_capacity(n);
    let mut seg = 0;
    for i in 0..n {
        while seg + 1 < anchors.len() && anchors[seg + 1].0 <= i {
            seg += 1;
        }
        let t = if i < first.0 {
            first.1 - (first.0 - i) as f64 * mean
        } else if seg + 1 < anchors.len() {
            let (a, b) = (anchors[seg], anchors[seg + 1]);
            a.1 + (i - a.0) as f64 * (b.1 - a.1) / (b.0 - a.0) as f64
        } else {
            last.1 + (i - last.0) as f64 * mean
        };
        times.push(t);
    }
    let shift = times[0];
    if let Some(i) = times.iter().position(|t| !(t - shift).is_finite() || t - shift > MAX_SPAN_NS) {
        return Err(i);
    }
    // Relative times in f64 (nanoseconds since the first stamp: exact to 2^53 ns, 104 days), the
    // first stamp added as an integer (1e18 ns as f64 would be 256 ns coarse).
    let mut out: Vec<u64> =
        times.iter().map(|t| stamps[0].saturating_add((t - shift).round().max(0.0) as u64)).collect();
    for i in 1..n {
        if out[i] <= out[i - 1] {
            out[i] = out[i - 1].saturating_add(1);
        }
    }
    Ok((out, spacing))
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: u64 = 1_000_000_000;

    #[test]
    fn printed_steps_are_read_from_the_text() {
        assert_eq!(printed_quantum_ns("1.13486e+09"), 10_000 * S);
        assert_eq!(printed_quantum_ns("0.204947"), 1_000);
        assert_eq!(printed_quantum_ns("1339.08"), 10_000_000);
        assert_eq!(printed_quantum_ns("12"), S);
        assert_eq!(printed_quantum_ns("1.5E2"), 10 * S);
        assert_eq!(printed_quantum_ns("0.0000000001"), 1, "at least a nanosecond");
        // Exponents past i32 (a value Rust reads as 0 or inf) neither overflow nor panic.
        assert_eq!(printed_quantum_ns("0.5e-2147483648"), 1);
        assert_eq!(printed_quantum_ns("5e2147483647"), u64::MAX);
    }

    #[test]
    fn sane_stamps_are_trusted_and_a_few_steps_back_too() {
        let stamps: Vec<u64> = (0..100).map(|k| k * S / 5).collect();
        let s = StreamStamps::of("FLASER", &stamps, &[1_000; 100], |i| format!("line {i}"));
        assert_eq!(s.distrust(), None);
        let mut back = stamps.clone();
        back.swap(10, 11);
        back.swap(40, 41);
        assert_eq!(StreamStamps::of("x", &back, &[], |i| format!("{i}")).distrust(), None, "2 steps back stay clamped");
    }

    #[test]
    fn coarse_repeated_and_disordered_stamps_are_distrusted_with_the_reason() {
        let coarse = vec![1_134_860_000 * S; 50];
        let s = StreamStamps::of("FLASER", &coarse, &[10_000 * S; 50], |i| format!("line {}", i + 3));
        let why = s.distrust().unwrap();
        assert!(why.contains("49 of 49 consecutive stamps repeat") && why.contains("first at line 4"), "{why}");
        assert!(why.contains("printed to 10000 s"), "{why}");
        // Exact stamps that go back and forth.
        let zigzag: Vec<u64> = (0..40).map(|k| if k % 2 == 0 { k * S + 3 * S } else { k * S }).collect();
        let why = StreamStamps::of("/odom", &zigzag, &[], |i| format!("message {i}")).distrust().unwrap();
        assert!(why.contains("0 of 39") && why.contains("20 step back") && why.contains("first at message 1"), "{why}");
        // A step coarser than the spacing without repeats in a stream (rising by 1 ns is no time).
        let fine_but_coarse: Vec<u64> = (0..10).map(|k| k * 10).collect();
        let s = StreamStamps::of("x", &fine_but_coarse, &[S; 10], |i| format!("{i}"));
        assert!(s.coarse() && s.distrust().unwrap().contains("coarser than"));
    }

    #[test]
    fn fine_stamps_timed_by_order_keep_their_times() {
        let stamps: Vec<u64> = vec![5 * S, 6 * S, 8 * S, 9 * S];
        let (t, spacing) = by_order(&stamps, 1_000, &[0, 2], None).unwrap();
        assert_eq!(t, stamps);
        assert_eq!(spacing, Spacing::Printed { anchors: 4 });
        // Repeats within fine stamps are spread evenly up to the next change.
        let (t, _) = by_order(&[5 * S, 5 * S, 5 * S, 8 * S], 1_000, &[], None).unwrap();
        assert_eq!(t, vec![5 * S, 6 * S, 7 * S, 8 * S]);
    }

    #[test]
    fn coarse_stamps_are_anchored_where_they_change() {
        // True times 0.5 s apart, printed to 2 s: the printed value changes every 4 messages, at
        // the crossings; the spacing between crossings is recovered, and continues at the ends.
        let stamps: Vec<u64> = (0..20).map(|k| (k as u64 + 1) / 4 * 2 * S).collect();
        let (t, spacing) = by_order(&stamps, 2 * S, &[], None).unwrap();
        assert_eq!(spacing, Spacing::Printed { anchors: 5 });
        for w in t.windows(2) {
            assert_eq!(w[1] - w[0], S / 2, "{t:?}");
        }
        assert_eq!(t[0], 0, "starts at the first printed stamp");
    }

    #[test]
    fn a_first_stamp_far_from_the_rest_is_refused_not_spread_over_years() {
        // A stamp of 0 (a negative stamp read as 0) before %g epoch stamps: one "change" of 36
        // years. Not a spacing: refused where the time runs away, never overflowing.
        let mut stamps = vec![1_134_860_000 * S; 20];
        stamps[0] = 0;
        let r = by_order(&stamps, 10_000 * S, &[0, 5, 10, 15], None);
        assert!(r.is_err(), "{r:?}");
        // With a rate the lines are timed from it.
        let (t, _) = by_order(&stamps, 10_000 * S, &[0, 5, 10, 15], Some(5.0)).unwrap();
        assert!(t.windows(2).all(|w| w[1] > w[0]) && t[19] - t[0] < 10 * S, "{t:?}");
    }

    #[test]
    fn without_changes_or_a_rate_the_time_is_lost_and_a_rate_restores_it() {
        let stamps = vec![1_134_860_000 * S; 9];
        assert_eq!(by_order(&stamps, 10_000 * S, &[0, 3, 6], None), Err(0));
        let (t, spacing) = by_order(&stamps, 10_000 * S, &[0, 3, 6], Some(2.0)).unwrap();
        assert_eq!(spacing, Spacing::Rate(2.0));
        // Scans at 0, 0.5, 1.0 s after the first stamp; two messages evenly between each.
        let rel: Vec<u64> = t.iter().map(|x| x - t[0]).collect();
        let third = S / 6;
        assert_eq!(rel[3], S / 2);
        assert_eq!(rel[6], S);
        assert!(rel[1].abs_diff(third) <= 1 && rel[8].abs_diff(S + 2 * third) <= 1, "{rel:?}");
        assert!(t.windows(2).all(|w| w[1] > w[0]));
    }
}
