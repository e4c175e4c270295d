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
