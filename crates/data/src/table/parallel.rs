//! The parallel CSV scan: blocks of whole lines parsed by the fast path on
//! several threads, the rows visited in file order on the calling thread,
//! the sequential reader taking over from a line the fast path does not
//! take.

use super::*;

/// A block of whole lines of a CSV file for [`scan_parallel`], and what the
/// fast path made of it ([`parse_block`]). Its buffers are reused.
#[derive(Default)]
pub(super) struct Block {
    /// Its number in the file (0, 1, …).
    pub(super) seq: u64,
    /// Offset in the file of its first byte, the start of a line.
    pub(super) start: u64,
    /// The bytes `raw[..len]`: whole lines, each ended by `\n` except the
    /// file's last.
    pub(super) raw: Vec<u8>,
    pub(super) len: usize,
    /// Whether [`parse_block`] has run.
    pub(super) parsed: bool,
    /// The values of the rows the fast path took, `rows` × `needed`.
    pub(super) vals: Vec<f64>,
    pub(super) rows: usize,
    /// (r, n): n blank lines before row r (r = `rows`: before the `stop`
    /// line), ascending.
    pub(super) gaps: Vec<(usize, u64)>,
    /// Line ends (`\n`) in `raw[..stop]` (`raw[..len]` without a stop).
    pub(super) newlines: u64,
    /// The start (in `raw`) of the first line the fast path does not take:
    /// the rest of the block is to be read by `csv-core`.
    pub(super) stop: Option<usize>,
}

impl Block {
    /// Line ends before the block's first row or its stop line.
    pub(super) fn lead(&self) -> u64 {
        match self.gaps.first() {
            Some(&(0, n)) => n,
            _ => 0,
        }
    }
}

/// Parses a block through the fast path (the loop of [`scan_sequential`]
/// without `csv-core`: blank lines skipped, then [`fast_line`]) up to its
/// end or the first line the fast path does not take. O(block); no
/// allocation once the block's buffers have grown.
pub(super) fn parse_block(blk: &mut Block, plan: &Plan, needed: usize) {
    let b = &blk.raw[..blk.len];
    blk.gaps.clear();
    blk.stop = None;
    let (mut i, mut rows, mut newlines) = (0, 0, 0u64);
    loop {
        let mut blank = 0;
        while let Some(&c) = b.get(i) {
            match c {
                b'\n' => blank += 1,
                b'\r' => {}
                _ => break,
            }
            i += 1;
        }
        newlines += blank;
        if i == b.len() {
            break;
        }
        if blank > 0 {
            blk.gaps.push((rows, blank));
        }
        let at = rows * needed;
        if blk.vals.len() < at + needed {
            let n = (2 * blk.vals.len()).max(at + needed).max(1024);
            blk.vals.resize(n, 0.0);
        }
        match fast_line(&b[i..], plan, &mut blk.vals[at..at + needed]) {
            Some(len) if len > 0 => {
                i += len;
                newlines += u64::from(b[i - 1] == b'\n');
                rows += 1;
            }
            _ => {
                blk.stop = Some(i);
                break;
            }
        }
    }
    blk.rows = rows;
    blk.newlines = newlines;
    blk.parsed = true;
}

/// Cuts a CSV file into blocks of whole lines of about `block` bytes (the
/// bytes up to the last `\n` once `block` bytes are read) for
/// [`scan_parallel`].
pub(super) struct Chunker<'a> {
    pub(super) src: FileAt<'a>,
    /// The bytes read after the previous block (a part of a line).
    pub(super) carry: Vec<u8>,
    /// Offset in the file of the next block.
    pub(super) next: u64,
    pub(super) block: usize,
    /// The largest block: a longer line stops the cutting.
    pub(super) limit: usize,
    pub(super) eof: bool,
    /// Where the cutting stopped before the end of the file (a line longer
    /// than `limit`, or a read error): the rest is read sequentially (which
    /// reports the error with its line).
    pub(super) stopped: Option<u64>,
}

impl Chunker<'_> {
    /// Fills `blk` with the next block; false when there is none (the end of
    /// the file, or `stopped`). O(block).
    pub(super) fn fill(&mut self, blk: &mut Block) -> bool {
        if self.stopped.is_some() || (self.eof && self.carry.is_empty()) {
            return false;
        }
        let mut len = self.carry.len();
        if blk.raw.len() < len.max(self.block) {
            blk.raw.resize(len.max(self.block), 0);
        }
        blk.raw[..len].copy_from_slice(&self.carry);
        self.carry.clear();
        // No `\n` in raw[..searched] (the carry has none).
        let mut searched = len;
        while !self.eof {
            if len >= self.block {
                if let Some(k) = memchr::memrchr(b'\n', &blk.raw[searched..len]) {
                    let cut = searched + k + 1;
                    self.carry.extend_from_slice(&blk.raw[cut..len]);
                    len = cut;
                    break;
                }
                searched = len;
                if len >= self.limit {
                    self.stopped = Some(self.next);
                    return false;
                }
            }
            if len == blk.raw.len() {
                blk.raw.resize(2 * len, 0);
            }
            match std::io::Read::read(&mut self.src, &mut blk.raw[len..]) {
                Ok(0) => self.eof = true,
                Ok(n) => len += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(_) => {
                    self.stopped = Some(self.next);
                    return false;
                }
            }
        }
        if len == 0 {
            return false;
        }
        blk.start = self.next;
        blk.len = len;
        blk.parsed = false;
        self.next += len as u64;
        true
    }
}

/// The blocks between the calling thread and the helpers of
/// [`scan_parallel`].
#[derive(Default)]
pub(super) struct Queue {
    /// Read, not yet parsed, in file order.
    pub(super) todo: std::collections::VecDeque<Block>,
    /// Parsed, not yet taken.
    pub(super) done: Vec<Block>,
    /// The helpers are to stop.
    pub(super) quit: bool,
    /// A helper panicked (its block is lost).
    pub(super) failed: bool,
}

#[derive(Default)]
pub(super) struct Shared {
    pub(super) queue: std::sync::Mutex<Queue>,
    /// A block to parse, or `quit`.
    pub(super) work: std::sync::Condvar,
    /// A block parsed, or `failed`.
    pub(super) done: std::sync::Condvar,
}

impl Shared {
    pub(super) fn lock(&self) -> std::sync::MutexGuard<'_, Queue> {
        self.queue
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Hands a block read to the parsers.
    pub(super) fn push(&self, blk: Block) {
        self.lock().todo.push_back(blk);
        self.work.notify_one();
    }

    /// Takes block `seq` (read, not yet taken), parsed or not. With `help`,
    /// parses the oldest unclaimed block while `seq` is being parsed by a
    /// helper.
    pub(super) fn take(&self, seq: u64, help: Option<(&Plan, usize)>) -> Block {
        let mut q = self.lock();
        loop {
            if let Some(k) = q.done.iter().position(|b| b.seq == seq) {
                return q.done.swap_remove(k);
            }
            if q.todo.front().is_some_and(|b| b.seq == seq)
                && let Some(b) = q.todo.pop_front()
            {
                return b;
            }
            assert!(!q.failed, "a CSV parsing thread panicked");
            if let Some((plan, needed)) = help
                && let Some(mut b) = q.todo.pop_front()
            {
                drop(q);
                parse_block(&mut b, plan, needed);
                q = self.lock();
                q.done.push(b);
                continue;
            }
            q = self
                .done
                .wait(q)
                .unwrap_or_else(std::sync::PoisonError::into_inner);
        }
    }

    /// A helper: parses the blocks it takes from `todo` until `quit`.
    pub(super) fn help(&self, plan: &Plan, needed: usize) {
        // Tells the calling thread if this one panics (it would wait forever).
        struct Failed<'s>(&'s Shared);
        impl Drop for Failed<'_> {
            fn drop(&mut self) {
                if std::thread::panicking() {
                    self.0.lock().failed = true;
                    self.0.done.notify_all();
                }
            }
        }
        let _failed = Failed(self);
        let mut q = self.lock();
        loop {
            if q.quit {
                return;
            }
            if let Some(mut b) = q.todo.pop_front() {
                drop(q);
                parse_block(&mut b, plan, needed);
                q = self.lock();
                q.done.push(b);
                self.done.notify_one();
            } else {
                q = self
                    .work
                    .wait(q)
                    .unwrap_or_else(std::sync::PoisonError::into_inner);
            }
        }
    }
}

/// Stops the helpers when dropped (at the end of the scan or on an error).
pub(super) struct Quit<'s>(pub(super) &'s Shared);

impl Drop for Quit<'_> {
    fn drop(&mut self) {
        self.0.lock().quit = true;
        self.0.work.notify_all();
    }
}

/// What the rows of a block left to do.
pub(super) enum After {
    /// `visit` asked to stop.
    Stop,
    /// Go on with the next block, which starts at this line.
    Next(u64),
    /// Read sequentially from this offset, the start of this line.
    Sequential(u64, u64),
}

/// Visits the rows of a parsed block whose first line is `line`.
pub(super) fn consume<V: FnMut(&[f64]) -> crate::Result<bool>>(
    blk: &Block,
    line: u64,
    lay: &Layout,
    sink: &mut Sink<V>,
    row: &mut [f64],
) -> crate::Result<After> {
    let needed = lay.needed;
    let mut gaps = blk.gaps.iter().peekable();
    let mut newlines = 0;
    for r in 0..blk.rows {
        if let Some(&&(g, n)) = gaps.peek()
            && g == r
        {
            newlines += n;
            gaps.next();
        }
        let v = &blk.vals[r * needed..(r + 1) * needed];
        for (x, &s) in row.iter_mut().zip(&lay.from) {
            *x = v[s];
        }
        let t = lay.time_slot.map_or(f64::NAN, |s| v[s]);
        if !sink.row(lay, row, line + newlines, t)? {
            return Ok(After::Stop);
        }
        newlines += 1;
    }
    Ok(match blk.stop {
        Some(q) => After::Sequential(blk.start + q as u64, line + blk.newlines),
        None => After::Next(line + blk.newlines),
    })
}

/// Reads the rows after the header with `threads` parsers: the calling
/// thread cuts the file into blocks of whole lines ([`Chunker`]), at most
/// 2 × `threads` of them in flight; `threads` − 1 helpers and the calling
/// thread (while the next block is being parsed) run the fast path on them
/// ([`parse_block`]); the calling thread visits the rows in file order,
/// counting lines from the blocks' line ends.
///
/// A block the fast path does not take to its end is read from its stop
/// line on by `rd` (the sequential reader: `csv-core`, [`cell_value`] and
/// their messages) until `rd` is between two records at the start of a
/// later block: the fast path's rows of that block are then the
/// sequential reader's, and the blocks take over again (blocks passed over
/// are dropped). So the rows, checks and messages are those of
/// [`scan_sequential`]. Memory O(threads × block + longest line).
pub(super) fn scan_parallel<V: FnMut(&[f64]) -> crate::Result<bool>>(
    mut rd: CsvReader<FileAt<'_>>,
    lay: &Layout,
    threads: usize,
    block: usize,
    sink: &mut Sink<V>,
) -> crate::Result<()> {
    let block = block.max(1);
    let mut chunker = Chunker {
        src: FileAt {
            file: rd.src.file,
            at: rd.src.at,
        },
        carry: rd.buf[rd.pos..rd.filled].to_vec(),
        next: rd.offset(),
        block,
        limit: block.saturating_mul(16).max(1 << 12),
        eof: rd.eof,
        stopped: None,
    };
    let shared = Shared::default();
    let (plan, needed) = (&lay.plan, lay.needed);
    std::thread::scope(|s| {
        for _ in 1..threads {
            // Without a helper the calling thread parses every block.
            let _ = std::thread::Builder::new()
                .name("lifted-csv".into())
                .spawn_scoped(s, || shared.help(plan, needed));
        }
        let _quit = Quit(&shared);
        let in_flight = 2 * threads.max(1);
        let mut row = vec![0.0; lay.wanted.len()];
        let mut vals = vec![0.0; needed];
        let mut free: Vec<Block> = Vec::new();
        // Starts of the blocks read and not yet taken; the first is block `taken`.
        let mut pending = std::collections::VecDeque::new();
        let (mut read, mut taken) = (0u64, 0u64);
        // A block to visit next (after switching back from `rd`).
        let mut ready: Option<Block> = None;
        // Some(line of the next block's start): visiting blocks; None:
        // reading with `rd`.
        let mut line = Some(rd.line);
        loop {
            while pending.len() < in_flight {
                let mut blk = free.pop().unwrap_or_default();
                if !chunker.fill(&mut blk) {
                    free.push(blk);
                    break;
                }
                blk.seq = read;
                read += 1;
                pending.push_back(blk.start);
                shared.push(blk);
            }
            if let Some(at) = line {
                let mut blk = match ready.take() {
                    Some(blk) => blk,
                    None if pending.pop_front().is_some() => {
                        taken += 1;
                        shared.take(taken - 1, Some((plan, needed)))
                    }
                    None => match chunker.stopped {
                        Some(next) => {
                            rd.seek_to(next, at);
                            line = None;
                            continue;
                        }
                        None => return Ok(()), // the end of the file
                    },
                };
                if !blk.parsed {
                    parse_block(&mut blk, plan, needed);
                }
                let after = consume(&blk, at, lay, sink, &mut row)?;
                free.push(blk);
                match after {
                    After::Stop => return Ok(()),
                    After::Next(next) => line = Some(next),
                    After::Sequential(offset, at) => {
                        rd.seek_to(offset, at);
                        line = None;
                    }
                }
                continue;
            }
            // One record with `rd`, the blocks it passes dropped; at a block
            // start between two records (before or among blank lines), the
            // blocks take over.
            let p0 = rd.offset();
            let more = rd
                .skip_blank_lines()
                .map_err(|e| input(format!("{}: line {}: {e}", lay.path, rd.line)))?;
            let p1 = rd.offset();
            while let Some(&start) = pending.front() {
                if start > p1 {
                    break;
                }
                pending.pop_front();
                taken += 1;
                let mut blk = shared.take(taken - 1, None);
                if start >= p0 {
                    if !blk.parsed {
                        parse_block(&mut blk, plan, needed);
                    }
                    if blk.rows > 0 || blk.stop.is_some() {
                        // Its first row or stop line is at p1, line rd.line.
                        line = Some(rd.line - blk.lead());
                        ready = Some(blk);
                        break;
                    }
                }
                free.push(blk);
            }
            if line.is_some() {
                continue;
            }
            if !more {
                return Ok(());
            }
            match read_one(&mut rd, lay, true, &mut vals, &mut row)? {
                Step::End => return Ok(()),
                Step::Blank => {}
                Step::Row(at, t) => {
                    #[cfg(test)]
                    tests::SEQUENTIAL_ROWS.with(|n| n.set(n.get() + 1));
                    if !sink.row(lay, &row, at, t)? {
                        return Ok(());
                    }
                }
            }
        }
    })
}
