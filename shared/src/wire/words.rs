//! Payload words: where encoded words go, and sending them without a copy.

use core::mem::MaybeUninit;
use iceoryx2::prelude::ZeroCopySend;

/// Where encoded words go: a `Vec`, or a loaned sample's memory.
pub trait WordSink {
    fn put(&mut self, word: u64);
}

impl WordSink for Vec<u64> {
    fn put(&mut self, word: u64) {
        self.push(word);
    }
}

/// Writes words into uninitialised memory, counting them: `filled` tells
/// whether every word was written (and no more were offered).
pub struct UninitWords<'a> {
    out: &'a mut [MaybeUninit<u64>],
    at: usize,
    overrun: bool,
}

impl<'a> UninitWords<'a> {
    pub fn new(out: &'a mut [MaybeUninit<u64>]) -> Self {
        UninitWords {
            out,
            at: 0,
            overrun: false,
        }
    }
    /// Every word of the memory written, and none offered past it.
    pub fn filled(&self) -> bool {
        self.at == self.out.len() && !self.overrun
    }
}

impl WordSink for UninitWords<'_> {
    fn put(&mut self, word: u64) {
        match self.out.get_mut(self.at) {
            Some(w) => {
                w.write(word);
                self.at += 1;
            }
            None => self.overrun = true,
        }
    }
}

pub(crate) fn put_f64s(sink: &mut impl WordSink, xs: &[f64]) {
    for x in xs {
        sink.put(x.to_bits());
    }
}

pub(crate) fn pair(lo: u32, hi: u32) -> u64 {
    u64::from(lo) | (u64::from(hi) << 32)
}

pub(crate) fn split(w: u64) -> (u32, u32) {
    (w as u32, (w >> 32) as u32)
}

pub(crate) fn f3(w: &[u64]) -> [f64; 3] {
    [
        f64::from_bits(w[0]),
        f64::from_bits(w[1]),
        f64::from_bits(w[2]),
    ]
}

/// Sends a message of `header` and `len` words that `encode` writes into
/// the loaned sample (no copy on the way). Fails with
/// [`SendError::Incomplete`] if `encode` did not write exactly `len` words.
pub fn send_words<S: iceoryx2::service::Service, H: core::fmt::Debug + Default + ZeroCopySend>(
    publisher: &iceoryx2::port::publisher::Publisher<S, [u64], H>,
    header: H,
    len: usize,
    encode: impl FnOnce(&mut UninitWords<'_>),
) -> Result<usize, SendError> {
    let mut sample = publisher.loan_slice_uninit(len).map_err(SendError::Loan)?;
    *sample.user_header_mut() = header;
    let mut words = UninitWords::new(sample.payload_mut());
    encode(&mut words);
    if !words.filled() {
        return Err(SendError::Incomplete { words: len });
    }
    // SAFETY: `filled` says every one of the sample's `len` words was
    // written above (`UninitWords` writes each word it is given into the
    // next place and counts them), so the payload is initialised.
    let sample = unsafe { sample.assume_init() };
    sample.send().map_err(SendError::Send)
}

/// Why a message could not be sent.
#[derive(Debug)]
pub enum SendError {
    /// The publisher could not loan a sample of that many words.
    Loan(iceoryx2::port::LoanError),
    /// The encoder wrote more or fewer words than the sample holds.
    Incomplete {
        words: usize,
    },
    Send(iceoryx2::port::SendError),
}

impl core::fmt::Display for SendError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SendError::Loan(e) => write!(f, "cannot loan a sample: {e:?}"),
            SendError::Incomplete { words } => {
                write!(f, "the message did not fill its {words} words")
            }
            SendError::Send(e) => write!(f, "cannot send: {e:?}"),
        }
    }
}
