//! The logs of a serve run: `inputs.csv` (what the controllers sent,
//! taken or rejected) and `replay.csv` (what the engine received, in
//! order, with the state hash after every step: enough to re-run the
//! session bit for bit).
//!
//! `replay.csv` rows, `op,step,index,v0..v5`:
//! - `torque,k,j,x,y,z`: joint j's torque from step k on (changes only);
//! - `motor,k,j,v`: joint j's motor target from step k on (changes only);
//! - `impulse,k,b,lx,ly,lz,ax,ay,az`: an impulse on body b for step k;
//! - `step,k,,HASH`: the engine took the step from state k; HASH (16 hex
//!   digits) is the state hash after it (unchanged state if it failed);
//! - `reset,k`, `snapshot,k,id`, `restore,k,id`: control commands.
//!
//! Floats are written as the shortest text that reads back to the same
//! bits.

use crate::output::num;
use cosim_shared::wire::InputFrame;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

pub const REPLAY_HEADER: &str = "op,step,index,v0,v1,v2,v3,v4,v5";
pub const INPUTS_HEADER: &str = "step,controller,sequence,status,kind,index,x,y,z,ax,ay,az";

pub struct Logs {
    replay: BufWriter<File>,
    inputs: BufWriter<File>,
}

impl Logs {
    pub fn create(dir: &Path) -> io::Result<Logs> {
        let open = |name: &str, header: &str| -> io::Result<BufWriter<File>> {
            let path = dir.join(name);
            let mut w = BufWriter::new(File::create(&path).map_err(|e| {
                io::Error::new(e.kind(), format!("cannot create {}: {e}", path.display()))
            })?);
            writeln!(w, "{header}")?;
            Ok(w)
        };
        Ok(Logs {
            replay: open("replay.csv", REPLAY_HEADER)?,
            inputs: open("inputs.csv", INPUTS_HEADER)?,
        })
    }

    pub fn torque(&mut self, step: u64, joint: usize, t: [f64; 3]) -> io::Result<()> {
        writeln!(
            self.replay,
            "torque,{step},{joint},{},{},{}",
            num(t[0]),
            num(t[1]),
            num(t[2])
        )
    }

    pub fn motor(&mut self, step: u64, joint: usize, speed: f64) -> io::Result<()> {
        writeln!(self.replay, "motor,{step},{joint},{}", num(speed))
    }

    pub fn impulse(&mut self, step: u64, body: usize, l: [f64; 3], a: [f64; 3]) -> io::Result<()> {
        write!(self.replay, "impulse,{step},{body}")?;
        for v in l.iter().chain(&a) {
            write!(self.replay, ",{}", num(*v))?;
        }
        writeln!(self.replay)
    }

    pub fn step(&mut self, step: u64, hash: u64) -> io::Result<()> {
        writeln!(self.replay, "step,{step},,{hash:016x}")
    }

    pub fn event(&mut self, op: &str, step: u64, id: Option<u64>) -> io::Result<()> {
        match id {
            Some(id) => writeln!(self.replay, "{op},{step},{id}"),
            None => writeln!(self.replay, "{op},{step}"),
        }
    }

    /// One input frame: a row per torque, impulse and motor target (its
    /// speed in `x`) with `status` (
    /// `applied`, or the reason it was rejected), so that a rejected input
    /// keeps the values sent (issue 15: it kept only the reason). A frame
    /// with neither gets one row without values (so does a `bad_count`
    /// frame, whose words did not match its counts).
    pub fn input(&mut self, f: &InputFrame, status: &str) -> io::Result<()> {
        let head = format!("{},{},{},{status}", f.step, f.controller_id, f.sequence);
        if f.torques.is_empty() && f.impulses.is_empty() && f.motors.is_empty() {
            return writeln!(self.inputs, "{head},,,,,,,,");
        }
        for t in &f.torques {
            writeln!(
                self.inputs,
                "{head},torque,{},{},{},{},,,",
                t.joint,
                num(t.torque[0]),
                num(t.torque[1]),
                num(t.torque[2])
            )?;
        }
        for b in &f.impulses {
            write!(self.inputs, "{head},impulse,{}", b.body)?;
            for v in b.linear.iter().chain(&b.angular) {
                write!(self.inputs, ",{}", num(*v))?;
            }
            writeln!(self.inputs)?;
        }
        for m in &f.motors {
            writeln!(
                self.inputs,
                "{head},motor,{},{},,,,,",
                m.joint,
                num(m.speed)
            )?;
        }
        Ok(())
    }

    pub fn flush(&mut self) -> io::Result<()> {
        self.replay.flush()?;
        self.inputs.flush()
    }
}

/// One row of `replay.csv`.
#[derive(Debug, Clone, PartialEq)]
pub enum Op {
    Torque {
        step: u64,
        joint: usize,
        t: [f64; 3],
    },
    Motor {
        step: u64,
        joint: usize,
        speed: f64,
    },
    Impulse {
        step: u64,
        body: usize,
        l: [f64; 3],
        a: [f64; 3],
    },
    Step {
        step: u64,
        hash: u64,
    },
    Reset {
        step: u64,
    },
    Snapshot {
        step: u64,
        id: u64,
    },
    Restore {
        step: u64,
        id: u64,
    },
}

/// The complete lines of a log that may have been cut off, and the number
/// (1-based) of the line that was cut, if one was. Every row ends in a
/// newline, so text after the last newline is a row the server was writing
/// when it was killed (issue 15, defect 10): it is dropped, whatever it
/// looks like (a hash cut short still parses as hex).
pub fn complete_lines(text: &str) -> (&str, Option<usize>) {
    if text.is_empty() || text.ends_with('\n') {
        return (text, None);
    }
    let end = text.rfind('\n').map_or(0, |i| i + 1);
    let complete = &text[..end];
    (complete, Some(complete.lines().count() + 1))
}

/// `replay.csv` read: its ops, and the line that was cut off, if any.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayLog {
    pub ops: Vec<Op>,
    pub cut_at: Option<usize>,
}

/// Reads `replay.csv` up to its last complete line; errors name the line
/// and the field.
pub fn read_replay(text: &str, file: &str) -> Result<ReplayLog, String> {
    let (text, cut_at) = complete_lines(text);
    let mut ops = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let c: Vec<&str> = line.split(',').collect();
        let at = |what: &str| format!("{file}:{}: {what}", k + 1);
        let int = |i: usize, what: &str| -> Result<u64, String> {
            c.get(i)
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| at(&format!("{what} = {:?} is not an integer", c.get(i))))
        };
        let float = |i: usize| -> Result<f64, String> {
            c.get(i)
                .and_then(|s| s.parse().ok())
                .ok_or_else(|| at(&format!("value {:?} is not a number", c.get(i))))
        };
        let step = int(1, "step")?;
        let op = match c[0] {
            "torque" => Op::Torque {
                step,
                joint: int(2, "joint")? as usize,
                t: [float(3)?, float(4)?, float(5)?],
            },
            "motor" => Op::Motor {
                step,
                joint: int(2, "joint")? as usize,
                speed: float(3)?,
            },
            "impulse" => Op::Impulse {
                step,
                body: int(2, "body")? as usize,
                l: [float(3)?, float(4)?, float(5)?],
                a: [float(6)?, float(7)?, float(8)?],
            },
            "step" => Op::Step {
                step,
                hash: c
                    .get(3)
                    .and_then(|s| u64::from_str_radix(s, 16).ok())
                    .ok_or_else(|| at("hash is not 16 hex digits"))?,
            },
            "reset" => Op::Reset { step },
            "snapshot" => Op::Snapshot {
                step,
                id: int(2, "snapshot id")?,
            },
            "restore" => Op::Restore {
                step,
                id: int(2, "snapshot id")?,
            },
            other => return Err(at(&format!("unknown op {other:?}"))),
        };
        ops.push(op);
    }
    Ok(ReplayLog { ops, cut_at })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cut_last_line_is_dropped_and_named() {
        assert_eq!(complete_lines(""), ("", None));
        assert_eq!(complete_lines("h\na\n"), ("h\na\n", None));
        assert_eq!(complete_lines("h\na\nste"), ("h\na\n", Some(3)));
        assert_eq!(complete_lines("hea"), ("", Some(1)));
        let text = format!("{REPLAY_HEADER}\nstep,0,,00000000000000ff\nstep,1,,00ab");
        let log = read_replay(&text, "replay.csv").unwrap();
        assert_eq!(
            log.ops,
            vec![Op::Step {
                step: 0,
                hash: 0xff
            }]
        );
        assert_eq!(log.cut_at, Some(3));
    }
}
