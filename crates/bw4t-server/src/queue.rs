//! A connection's queue of outgoing lines, bounded in lines: the match task and the
//! connection's reader add to it, and its writer takes everything queued at once, so what
//! a tick sends a connection wakes its writer once and leaves in one write.

use std::sync::{Arc, Mutex, MutexGuard, PoisonError};

use tokio::sync::Notify;

/// The adding end of a connection's queue; cloned for each task that adds lines. When
/// every clone is gone, the writer sends what is queued and ends, as if asked to close.
pub(crate) struct LineQueue {
    shared: Arc<Shared>,
}

/// The writer's end of a connection's queue.
pub(crate) struct QueueReader {
    shared: Arc<Shared>,
}

struct Shared {
    state: Mutex<State>,
    /// Woken when lines are added, the queue is closed or its last adder is gone.
    added: Notify,
    /// Lines the queue holds, counting those its writer is still writing.
    capacity: usize,
}

struct State {
    lines: Vec<Arc<str>>,
    /// Lines the writer took and has not finished writing.
    writing: usize,
    /// Asked to close after the lines queued before.
    closed: bool,
    adders: usize,
}

impl State {
    fn room(&self, capacity: usize) -> usize {
        capacity.saturating_sub(self.lines.len() + self.writing)
    }
}

/// A queue for `capacity` lines: its adding end and its writer's end.
pub(crate) fn line_queue(capacity: usize) -> (LineQueue, QueueReader) {
    let state = State { lines: Vec::new(), writing: 0, closed: false, adders: 1 };
    let shared = Arc::new(Shared { state: Mutex::new(state), added: Notify::new(), capacity });
    (LineQueue { shared: shared.clone() }, QueueReader { shared })
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, State> {
        // Nothing panics while the lock is held; a poisoned lock holds a consistent state.
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

impl LineQueue {
    /// Queues one line; false (and the line dropped) when the queue is full or closed.
    pub(crate) fn send(&self, line: Arc<str>) -> bool {
        {
            let mut state = self.shared.lock();
            if state.closed || state.room(self.shared.capacity) == 0 {
                return false;
            }
            state.lines.push(line);
        }
        self.shared.added.notify_one();
        true
    }

    /// Queues `lines` in order, as many as there is room for, and wakes the writer once;
    /// returns how many were queued.
    pub(crate) fn send_all(&self, lines: Vec<Arc<str>>) -> usize {
        let taken = {
            let mut state = self.shared.lock();
            if state.closed {
                return 0;
            }
            let taken = lines.len().min(state.room(self.shared.capacity));
            state.lines.extend(lines.into_iter().take(taken));
            taken
        };
        if taken > 0 {
            self.shared.added.notify_one();
        }
        taken
    }

    /// Asks the writer to close after the lines queued before; false (and nothing asked)
    /// when the queue is full, as a line would be refused.
    pub(crate) fn close(&self) -> bool {
        {
            let mut state = self.shared.lock();
            if state.room(self.shared.capacity) == 0 {
                return false;
            }
            state.closed = true;
        }
        self.shared.added.notify_one();
        true
    }

    /// Lines the queue can take now.
    pub(crate) fn room(&self) -> usize {
        self.shared.lock().room(self.shared.capacity)
    }
}

impl std::fmt::Debug for LineQueue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LineQueue").field("room", &self.room()).finish_non_exhaustive()
    }
}

impl Clone for LineQueue {
    fn clone(&self) -> LineQueue {
        self.shared.lock().adders += 1;
        LineQueue { shared: self.shared.clone() }
    }
}

impl Drop for LineQueue {
    fn drop(&mut self) {
        let last = {
            let mut state = self.shared.lock();
            state.adders -= 1;
            state.adders == 0
        };
        if last {
            self.shared.added.notify_one();
        }
    }
}

impl QueueReader {
    /// Waits for lines and moves every line queued into `batch` (which must be empty);
    /// false once the queue is closed (or has no adders left) and empty. The lines count
    /// against the room until [`Self::written`]. Cancel-safe: nothing is taken before it
    /// returns.
    pub(crate) async fn next_batch(&mut self, batch: &mut Vec<Arc<str>>) -> bool {
        loop {
            {
                let mut state = self.shared.lock();
                if !state.lines.is_empty() {
                    std::mem::swap(&mut state.lines, batch);
                    state.writing = batch.len();
                    return true;
                }
                if state.closed || state.adders == 0 {
                    return false;
                }
            }
            self.shared.added.notified().await;
        }
    }

    /// The batch last taken is written: its lines no longer count against the room.
    pub(crate) fn written(&mut self) {
        self.shared.lock().writing = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(texts: &[&str]) -> Vec<Arc<str>> {
        texts.iter().map(|t| Arc::from(*t)).collect()
    }

    #[tokio::test]
    async fn the_writer_takes_everything_queued_as_one_batch() {
        let (queue, mut reader) = line_queue(8);
        queue.send_all(lines(&["a\n", "b\n"]));
        assert!(queue.send("c\n".into()));
        let mut batch = Vec::new();
        assert!(reader.next_batch(&mut batch).await);
        assert_eq!(batch, lines(&["a\n", "b\n", "c\n"]));
    }

    #[tokio::test]
    async fn lines_being_written_count_against_the_room_until_written() {
        let (queue, mut reader) = line_queue(4);
        assert_eq!(queue.send_all(lines(&["a\n", "b\n", "c\n", "d\n", "e\n"])), 4);
        assert!(!queue.send("f\n".into()), "a full queue refuses lines");
        let mut batch = Vec::new();
        assert!(reader.next_batch(&mut batch).await);
        assert_eq!((batch.len(), queue.room()), (4, 0));
        batch.clear();
        reader.written();
        assert_eq!(queue.room(), 4);
    }

    #[tokio::test]
    async fn close_comes_after_the_lines_queued_before_and_refuses_later_ones() {
        let (queue, mut reader) = line_queue(4);
        queue.send("a\n".into());
        assert!(queue.close());
        assert!(!queue.send("b\n".into()));
        let mut batch = Vec::new();
        assert!(reader.next_batch(&mut batch).await);
        assert_eq!(batch, lines(&["a\n"]));
        batch.clear();
        assert!(!reader.next_batch(&mut batch).await);
    }

    #[tokio::test]
    async fn a_full_queue_cannot_be_closed_politely() {
        let (queue, _reader) = line_queue(1);
        queue.send("a\n".into());
        assert!(!queue.close());
    }

    #[tokio::test]
    async fn the_writer_ends_when_every_adder_is_gone() {
        let (queue, mut reader) = line_queue(4);
        let other = queue.clone();
        other.send("a\n".into());
        drop(queue);
        drop(other);
        let mut batch = Vec::new();
        assert!(reader.next_batch(&mut batch).await, "queued lines are still sent");
        batch.clear();
        assert!(!reader.next_batch(&mut batch).await);
    }
}
