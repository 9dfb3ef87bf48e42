//! `Controller`: a joined controller's lockstep (`next_state`, `send`,
//! `leave`; leaves on drop).

use crate::*;

/// A controller in the lockstep.
pub struct Controller {
    conn: Connection,
    id: u32,
    reader: StateReader,
    input: Publisher<ipc::Service, [u64], InputHeader>,
    wait: WaitMode,
    /// The step answered last, so that a frame published again for the same
    /// step (after a join or a pause) is not answered twice.
    answered: Option<u64>,
    /// The sequence of the frame answered last (a failed step's frame asks
    /// again only if it is newer).
    answered_sequence: u64,
    /// The last frame received (valid once `has_last`), read into the
    /// same buffers each step.
    last: StateFrame,
    has_last: bool,
    sequence: u64,
    info: ControlResponse,
    /// `leave` was called (a drop then sends no second one).
    left: bool,
}

impl Controller {
    /// Connects to server `name` and joins its lockstep.
    pub fn join(name: &str, wait: WaitMode) -> Result<Controller, ClientError> {
        let conn = Connection::connect(name)?;
        // Subscribe before joining: the server republishes the state when a
        // controller joins, and the history keeps the last frame anyway.
        // A spinning controller polls: without a listener, the server's
        // state event has nobody to wake for it (a system call saved per
        // step when every reader polls).
        let reader = StateReader::open(&conn.node, name, 2, wait != WaitMode::Spin)?;
        let info = conn.info()?;
        // Room for a torque and a motor target on every joint and a few
        // impulses; a larger input grows the publisher's memory
        // (power-of-two strategy), once.
        let joints = info.joint_count as usize;
        let words = input_words(joints, 8, joints);
        let input = conn
            .node
            .service_builder(&service_name(&services::input(name))?)
            .publish_subscribe::<[u64]>()
            .user_header::<InputHeader>()
            .open()
            .map_err(|e| missing(name, &services::input(name), e))?
            .publisher_builder()
            .initial_max_slice_len(words.max(1))
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| ipc("cannot publish inputs")(&e))?;
        let info = conn.request(
            ControlRequest {
                command: CMD_JOIN,
                role: ROLE_CONTROLLER,
                ..Default::default()
            },
            CONTROL_TIMEOUT,
        )?;
        Ok(Controller {
            id: info.controller_id,
            conn,
            reader,
            input,
            wait,
            answered: None,
            answered_sequence: 0,
            last: StateFrame::default(),
            has_last: false,
            sequence: 0,
            info,
            left: false,
        })
    }

    pub fn id(&self) -> u32 {
        self.id
    }

    /// The join answer: step size, counts, model hash.
    pub fn info(&self) -> &ControlResponse {
        &self.info
    }

    /// The scene's body and joint names, fetched from the server.
    pub fn names(&self) -> Result<Names, ClientError> {
        Names::fetch(&self.conn)
    }

    pub fn connection(&self) -> &Connection {
        &self.conn
    }

    /// The last frame received.
    pub fn last_state(&self) -> Option<&StateFrame> {
        self.has_last.then_some(&self.last)
    }

    /// Waits for the state of a step not yet answered. A frame with
    /// `STATUS_SHUTDOWN` ends the session with [`ClientError::Shutdown`].
    pub fn next_state(&mut self, timeout: Duration) -> Result<StateFrame, ClientError> {
        self.next_state_ref(timeout).cloned()
    }

    /// [`Controller::next_state`] without the copy: the frame stays in the
    /// controller (also [`Controller::last_state`]) until the next call,
    /// read into the same buffers every step.
    pub fn next_state_ref(&mut self, timeout: Duration) -> Result<&StateFrame, ClientError> {
        let answered = self.answered;
        let answered_sequence = self.answered_sequence;
        let id = self.id;
        let Controller {
            reader,
            conn,
            wait,
            last,
            ..
        } = self;
        reader.wait_with(
            &conn.node,
            *wait,
            timeout,
            true,
            // A frame that does not list this controller was published
            // before the join took effect (it may still sit in the buffer):
            // the server does not wait for this controller's answer to it.
            //
            // A frame of a failed step asks for a new answer to the same
            // step when its slot lacks SLOT_ANSWERED (protocol.md).
            |f| {
                let Some(slot) = f.controller(id) else {
                    return f.status & STATUS_SHUTDOWN != 0;
                };
                let again = f.status & STATUS_SOLVER_FAILED != 0
                    && slot.flags & SLOT_ANSWERED == 0
                    && f.sequence > answered_sequence;
                f.status & STATUS_SHUTDOWN != 0
                    || (f.status & STATUS_WAITING == 0 && (Some(f.step) != answered || again))
            },
            last,
        )?;
        self.has_last = true;
        if self.last.status & STATUS_SHUTDOWN != 0 {
            return Err(ClientError::Shutdown);
        }
        Ok(&self.last)
    }

    /// Sends `input` as the answer to the last state received.
    pub fn send(&mut self, mut input: InputFrame) -> Result<(), ClientError> {
        self.send_ref(&mut input)
    }

    /// [`Controller::send`] of a frame the caller keeps (and reuses).
    pub fn send_ref(&mut self, input: &mut InputFrame) -> Result<(), ClientError> {
        let step = if self.has_last { self.last.step } else { 0 };
        input.version = PROTOCOL_VERSION;
        input.controller_id = self.id;
        input.step = step;
        self.sequence += 1;
        input.sequence = self.sequence;
        self.send_raw(input)?;
        self.answered = Some(step);
        self.answered_sequence = if self.has_last { self.last.sequence } else { 0 };
        Ok(())
    }

    /// Sends a frame as it is (tests use it to send bad inputs).
    pub fn send_raw(&mut self, input: &InputFrame) -> Result<(), ClientError> {
        self.send_words(input.header(), input.words(), |w| input.encode(w))
    }

    /// Sends a header and `len` words that `encode` writes, as they are:
    /// tests and the fuzzer use it for headers whose counts do not match.
    pub fn send_words(
        &mut self,
        header: InputHeader,
        len: usize,
        encode: impl FnOnce(&mut UninitWords<'_>),
    ) -> Result<(), ClientError> {
        send_words(&self.input, header, len, encode)
            .map_err(|e| ipc("cannot send the input")(&e))?;
        // A spinning server needs no wake-up.
        if !self.has_last || self.last.status & STATUS_SERVER_SPINS == 0 {
            let _ = self.conn.wake.notify();
        }
        Ok(())
    }

    /// Leaves the lockstep; the server removes this controller's torques.
    /// A controller dropped without it leaves too (issue 15, defect 5).
    pub fn leave(mut self) -> Result<(), ClientError> {
        self.left = true;
        self.request_leave(CONTROL_TIMEOUT)
    }

    fn request_leave(&self, timeout: Duration) -> Result<(), ClientError> {
        self.conn
            .request(
                ControlRequest {
                    command: CMD_LEAVE,
                    controller_id: self.id,
                    ..Default::default()
                },
                timeout,
            )
            .map(|_| ())
    }
}

/// How long a dropped controller waits for the server to take its leave:
/// the server answers between steps, and a server that is gone must not
/// hold up the drop for long.
const LEAVE_ON_DROP: Duration = Duration::from_millis(500);

impl Drop for Controller {
    fn drop(&mut self) {
        if !self.left {
            // A server that is gone or already let this controller go
            // has nothing to answer: the error changes nothing here.
            let _ = self.request_leave(LEAVE_ON_DROP);
        }
    }
}
