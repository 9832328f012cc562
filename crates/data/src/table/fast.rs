//! The fast CSV path: a line of plain numbers split by a word-at-a-time
//! scan for `,`, only the wanted cells parsed (Clinger's exact fast path,
//! `fast-float2` for the rest); any other line goes to the csv-crate path.

/// What the fast path does with each cell of a line: per header column,
/// its slot in the parsed values (or [`SKIP`]) and whether a blank cell is
/// accepted (as NaN).
pub(super) struct Plan {
    pub(super) cols: Vec<(usize, bool)>,
}

/// A column the fast path only skips.
pub(super) const SKIP: usize = usize::MAX;

/// The index of the first `,`, `"`, `\r` or `\n` in `b[i..]` (or `b.len()`),
/// 8 bytes at a time (SWAR) while 8 are left. O(bytes skipped).
#[inline]
pub(super) fn find_special(b: &[u8], mut i: usize) -> usize {
    const LO: u64 = 0x0101_0101_0101_0101;
    const HI: u64 = 0x8080_8080_8080_8080;
    // High bit of each zero byte of x (exact up to the first zero byte).
    let zero = |x: u64| x.wrapping_sub(LO) & !x & HI;
    while let Some(chunk) = b.get(i..i + 8) {
        let mut a = [0u8; 8];
        a.copy_from_slice(chunk);
        let v = u64::from_le_bytes(a);
        let hit = zero(v ^ (LO * u64::from(b',')))
            | zero(v ^ (LO * u64::from(b'"')))
            | zero(v ^ (LO * u64::from(b'\r')))
            | zero(v ^ (LO * u64::from(b'\n')));
        if hit != 0 {
            return i + (hit.trailing_zeros() / 8) as usize;
        }
        i += 8;
    }
    while i < b.len() && !matches!(b[i], b',' | b'"' | b'\r' | b'\n') {
        i += 1;
    }
    i
}

/// The powers of ten exactly representable as f64.
pub(super) const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// The value of 8 ASCII digits read little-endian into `v` (SWAR).
#[inline]
pub(super) fn parse_8digits(v: u64) -> u64 {
    const MASK: u64 = 0x0000_00FF_0000_00FF;
    const MUL1: u64 = 0x000F_4240_0000_0064; // 100 + (1000000 << 32)
    const MUL2: u64 = 0x0000_2710_0000_0001; // 1 + (10000 << 32)
    let v = v.wrapping_sub(0x3030_3030_3030_3030);
    let v = v.wrapping_mul(10).wrapping_add(v >> 8);
    let v1 = (v & MASK).wrapping_mul(MUL1);
    let v2 = ((v >> 16) & MASK).wrapping_mul(MUL2);
    u64::from((v1.wrapping_add(v2) >> 32) as u32)
}

/// 10^n for n < 8.
pub(super) const POW10_U64: [u64; 8] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000];

/// Appends the run of ASCII digits at `b[i..]` to the decimal accumulator
/// `m` (wrapping: the caller discards more than 19 digits) and returns the
/// index after the run; 8 bytes at a time (SWAR) while 8 are left.
#[inline]
pub(super) fn digit_run(b: &[u8], mut i: usize, m: &mut u64) -> usize {
    while let Some(chunk) = b.get(i..i + 8) {
        let mut a = [0u8; 8];
        a.copy_from_slice(chunk);
        let v = u64::from_le_bytes(a);
        // A byte's high bit is set iff it is not a digit: x = c ^ '0' is
        // 0..=9 for a digit, and x + 0x76 reaches 0x80 for x ≥ 10. A carry
        // out of a byte only reaches bytes after a non-digit.
        let x = v ^ 0x3030_3030_3030_3030;
        let non_digit = (x.wrapping_add(0x7676_7676_7676_7676) | x) & 0x8080_8080_8080_8080;
        if non_digit == 0 {
            *m = m.wrapping_mul(100_000_000).wrapping_add(parse_8digits(v));
            i += 8;
            continue;
        }
        let n = (non_digit.trailing_zeros() / 8) as usize;
        if n > 0 {
            // The n digits moved to the top, '0's before them.
            let w = (v << (8 * (8 - n))) | (0x3030_3030_3030_3030 >> (8 * n));
            *m = m.wrapping_mul(POW10_U64[n]).wrapping_add(parse_8digits(w));
        }
        return i + n;
    }
    while i < b.len() {
        let d = b[i].wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        *m = m.wrapping_mul(10).wrapping_add(u64::from(d));
        i += 1;
    }
    i
}

/// Parses the common numbers at the start of `b` quickly: an optional sign,
/// at most 19 digits with an optional '.', an optional exponent of at most
/// 3 digits, whose value m·10^e has m ≤ 2^53 and |e| ≤ 22, so that one
/// correctly rounded product or quotient of exact f64 values (Clinger's fast
/// path) is the nearest f64, as `str::parse` gives (and finite). Returns the
/// value and the bytes used, or `None` for anything else (then `fast-float2`
/// is used). O(digits).
#[inline]
pub(super) fn parse_plain(b: &[u8]) -> Option<(f64, usize)> {
    let n = b.len();
    let (neg, start) = match b.first() {
        Some(b'-') => (true, 1),
        Some(b'+') => (false, 1),
        _ => (false, 0),
    };
    // The integer part, usually short: a byte at a time.
    let mut m: u64 = 0;
    let mut i = start;
    while i < n {
        let d = b[i].wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        m = m.wrapping_mul(10).wrapping_add(u64::from(d));
        i += 1;
    }
    let mut digits = i - start;
    let mut e: i64 = 0;
    if i < n && b[i] == b'.' {
        let from = i + 1;
        i = digit_run(b, from, &mut m);
        digits += i - from;
        e = -((i - from) as i64);
    }
    if digits == 0 || digits > 19 {
        return None;
    }
    if i < n && b[i] | 0x20 == b'e' {
        let mut j = i + 1;
        let eneg = match b.get(j) {
            Some(b'-') => {
                j += 1;
                true
            }
            Some(b'+') => {
                j += 1;
                false
            }
            _ => false,
        };
        let from = j;
        let mut x: i64 = 0;
        while j < n && j - from < 4 && b[j].is_ascii_digit() {
            x = 10 * x + i64::from(b[j] - b'0');
            j += 1;
        }
        if j == from || (j < n && b[j].is_ascii_digit()) {
            return None;
        }
        e += if eneg { -x } else { x };
        i = j;
    }
    if m > 1 << 53 || !(-22..=22).contains(&e) {
        return None;
    }
    let v = m as f64;
    let v = if e < 0 {
        v / POW10[(-e) as usize]
    } else {
        v * POW10[e as usize]
    };
    Some((if neg { -v } else { v }, i))
}

/// Parses the line at the start of `b` (which holds the whole line: up to
/// and with its `\n`, or to the end of the file) if its cells are plain
/// numbers: every needed cell a finite number (ASCII spaces and tabs around
/// it) or blank where allowed, the others free of quotes and carriage
/// returns, as many cells as the header, ended by `\n`, `\r\n` or the end of
/// the file. Returns the bytes of the line with its terminator; `None`
/// otherwise: the caller reads the line again with `csv-core` and
/// [`cell_value`](super::cell_value), which accept or reject it with the exact message. O(line).
#[inline]
pub(super) fn fast_line(b: &[u8], plan: &Plan, vals: &mut [f64]) -> Option<usize> {
    let width = plan.cols.len();
    let mut i = 0;
    for (c, &(slot, blank_ok)) in plan.cols.iter().enumerate() {
        if slot == SKIP {
            i = find_special(b, i);
        } else {
            while matches!(b.get(i), Some(b' ' | b'\t')) {
                i += 1;
            }
            let cell = &b[i..];
            let parsed = parse_plain(cell).or_else(|| {
                fast_float2::parse_partial::<f64, _>(cell)
                    .ok()
                    .filter(|(v, _)| v.is_finite())
            });
            match parsed {
                Some((v, len)) => {
                    vals[slot] = v;
                    i += len;
                    while matches!(b.get(i), Some(b' ' | b'\t')) {
                        i += 1;
                    }
                }
                // a blank cell if the cell ends here (checked below)
                None if blank_ok => vals[slot] = f64::NAN,
                None => return None,
            }
        }
        let last = c + 1 == width;
        match b.get(i) {
            Some(b',') if !last => i += 1,
            Some(b'\n') if last => return Some(i + 1),
            Some(b'\r') if last && b.get(i + 1) == Some(&b'\n') => return Some(i + 2),
            None if last => return Some(i),
            _ => return None,
        }
    }
    None
}
