//! The messages ranks of a distributed render send each other, behind one small trait: MPI
//! between processes (`--features mpi`, [`super::mpi`]), or in-process channels between
//! threads, so the compositing schemes run and are tested in the default build without MPI.

use crate::error::{Error, Result};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::Mutex;

/// Point-to-point byte messages between the `size()` ranks of a group. Messages between one
/// pair of ranks arrive in the order they were sent.
pub trait Exchange: Send + Sync {
    /// This rank, `0 .. size()`.
    fn rank(&self) -> usize;
    /// How many ranks the group has.
    fn size(&self) -> usize;
    fn send(&self, to: usize, data: &[u8]) -> Result<()>;
    fn recv(&self, from: usize) -> Result<Vec<u8>>;
    /// Sends `data` to `to` while receiving from `from`: two ranks that swap with each other
    /// cannot block on their sends.
    fn send_recv(&self, to: usize, data: &[u8], from: usize) -> Result<Vec<u8>>;
    /// What carries the messages, for the pass log ("MPI", "threads").
    fn transport(&self) -> &'static str;
}

/// `data` sent by `root` to every rank, along a binomial tree (log₂ N steps); every rank
/// returns it.
pub(crate) fn broadcast(ex: &dyn Exchange, root: usize, data: Vec<u8>) -> Result<Vec<u8>> {
    let n = ex.size();
    // Ranks relative to the root, so the tree is rooted at 0.
    let me = (ex.rank() + n - root) % n;
    let mut data = data;
    let mut span = 1;
    while span < n {
        span <<= 1;
    }
    // Receive from the parent (me with its lowest set bit cleared), then send to the children
    // (me plus each power of two below that bit).
    if me != 0 {
        let parent = me & (me - 1);
        data = ex.recv((parent + root) % n)?;
    }
    let mut step = span >> 1;
    while step > 0 {
        if me.is_multiple_of(step << 1) && me + step < n {
            ex.send((me + step + root) % n, &data)?;
        }
        step >>= 1;
    }
    Ok(data)
}

/// Every rank's `value` on rank 0, in rank order (empty on the others).
pub fn gather_u64(ex: &dyn Exchange, value: u64) -> Result<Vec<u64>> {
    if ex.rank() != 0 {
        ex.send(0, &value.to_le_bytes())?;
        return Ok(Vec::new());
    }
    let mut values = vec![value];
    for from in 1..ex.size() {
        let msg = ex.recv(from)?;
        let bytes: [u8; 8] = msg.as_slice().try_into().map_err(|_| {
            Error::invalid(
                "distributed",
                format!(
                    "rank {from} sent {} bytes, expected one 8-byte number",
                    msg.len()
                ),
            )
        })?;
        values.push(u64::from_le_bytes(bytes));
    }
    Ok(values)
}

/// Returns on every rank once every rank has called it (a gather onto rank 0, then its
/// broadcast).
pub(crate) fn barrier(ex: &dyn Exchange) -> Result<()> {
    gather_u64(ex, 0)?;
    broadcast(ex, 0, Vec::new()).map(drop)
}

/// One rank of a group of threads in one process, connected by channels.
pub struct ChannelExchange {
    rank: usize,
    to: Vec<Sender<Vec<u8>>>,
    from: Vec<Mutex<Receiver<Vec<u8>>>>,
}

impl ChannelExchange {
    /// The `n` ranks of a new group; hand one to each thread.
    pub fn group(n: usize) -> Vec<ChannelExchange> {
        // channels[a][b] carries messages from rank a to rank b.
        let mut senders: Vec<Vec<Sender<Vec<u8>>>> = (0..n).map(|_| Vec::new()).collect();
        let mut receivers: Vec<Vec<Mutex<Receiver<Vec<u8>>>>> =
            (0..n).map(|_| Vec::new()).collect();
        for sender in senders.iter_mut() {
            for receiver in receivers.iter_mut() {
                let (tx, rx) = channel();
                sender.push(tx);
                receiver.push(Mutex::new(rx));
            }
        }
        senders
            .into_iter()
            .zip(receivers)
            .enumerate()
            .map(|(rank, (to, from))| ChannelExchange { rank, to, from })
            .collect()
    }
}

fn peer_gone(what: &str, peer: usize) -> Error {
    Error::invalid(
        "distributed",
        format!("rank {peer} ended before it could {what}"),
    )
}

impl Exchange for ChannelExchange {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.to.len()
    }

    fn send(&self, to: usize, data: &[u8]) -> Result<()> {
        self.to[to]
            .send(data.to_vec())
            .map_err(|_| peer_gone("receive", to))
    }

    fn recv(&self, from: usize) -> Result<Vec<u8>> {
        self.from[from]
            .lock()
            .expect("channel poisoned")
            .recv()
            .map_err(|_| peer_gone("send", from))
    }

    fn send_recv(&self, to: usize, data: &[u8], from: usize) -> Result<Vec<u8>> {
        // Channel sends never block, so send first, then receive.
        self.send(to, data)?;
        self.recv(from)
    }

    fn transport(&self) -> &'static str {
        "threads"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gather_collects_in_rank_order_and_barrier_returns_on_every_rank() {
        let group = ChannelExchange::group(3);
        let gathered: Vec<Vec<u64>> = std::thread::scope(|scope| {
            let handles: Vec<_> = group
                .iter()
                .map(|ex| {
                    scope.spawn(move || {
                        barrier(ex).unwrap();
                        gather_u64(ex, 10 * ex.rank() as u64 + 7).unwrap()
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        assert_eq!(gathered, [vec![7, 17, 27], vec![], vec![]]);
        let short = ChannelExchange::group(2);
        short[1].send(0, &[1, 2, 3]).unwrap();
        let e = gather_u64(&short[0], 0).unwrap_err().to_string();
        assert!(e.contains("rank 1 sent 3 bytes"), "{e}");
    }
}
