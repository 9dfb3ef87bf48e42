use super::*;
use core::mem::{align_of, size_of};

fn state(k: usize, nb: usize, nj: usize, nc: usize) -> StateFrame {
    let mut x = k as f64;
    let mut next = || {
        x += 1.25;
        x
    };
    let mut f = StateFrame {
        step: k as u64,
        status: STATUS_CONTACTS_TRUNCATED,
        contact_count: nc as u32 + 3,
        residual: next(),
        ..StateFrame::default()
    };
    for _ in 0..nb {
        let v = next();
        f.bodies.push(BodyFrame {
            position: [v, -v, 0.5 * v],
            orientation: [1.0, 0.0, -0.0, v],
            linear_velocity: [f64::MIN_POSITIVE, v, 3.0],
            angular_velocity: [-v, 1e300, 0.0],
        });
    }
    for k in 0..nj {
        f.joint_impulses.push([next(); 3]);
        // A joint without a coordinate carries NaN.
        let c = if k % 2 == 0 {
            [next(), -next()]
        } else {
            [f64::NAN; 2]
        };
        f.joint_coordinates.push(c);
    }
    for i in 0..nc {
        let v = next();
        f.contacts.push(ContactFrame {
            body_a: i as u32,
            kind_b: CONTACT_BODY,
            index_b: u32::MAX - i as u32,
            id: 7 * i as u32,
            normal: [0.0, 0.0, v],
            friction: [v, -v, 0.0],
        });
    }
    f.controllers[k % MAX_CONTROLLERS].id = k as u32 + 1;
    f
}

/// Encoded and read back into a reused frame, every frame comes back
/// to the bit, whatever the sizes of the frames read into it before.
#[test]
fn frames_come_back_from_their_words() {
    let mut back = StateFrame::default();
    let mut input_back = InputFrame::default();
    for (k, &(nb, nj, nc)) in [
        (2, 2, 5),
        (3, 1, 0),
        (4000, 0, 16064),
        (1, 0, 70),
        (0, 0, 0),
    ]
    .iter()
    .enumerate()
    {
        let f = state(k, nb, nj, nc);
        let mut words = Vec::new();
        f.encode(&mut words);
        assert_eq!(words.len(), f.words());
        assert_eq!(words.len(), state_words(nb, nj, nc));
        back.read(&f.header(), &words).expect("well formed");
        // To the bit: NaN (a joint without a coordinate) is not equal
        // to itself, so the read frame is compared by its words.
        let mut again = Vec::new();
        back.encode(&mut again);
        assert_eq!(again, words, "frame {k}");
        assert_eq!(back.header(), f.header(), "frame {k}");
        assert_eq!(back.joint_coordinates.len(), nj);
        assert!(nj < 2 || back.joint_coordinates[1][0].is_nan());

        let mut input = InputFrame {
            step: k as u64,
            controller_id: 3,
            ..InputFrame::default()
        };
        for i in 0..nj {
            input.push_torque(i as u32, [1.5, 0.0, -(k as f64)]);
        }
        for i in 0..nb.min(50) {
            input.push_impulse(u32::MAX - i as u32, [0.5; 3], [-0.25; 3]);
        }
        for i in 0..nj.min(3) {
            input.push_motor(i as u32, -(k as f64) * 0.5);
        }
        let mut words = Vec::new();
        input.encode(&mut words);
        assert_eq!(words.len(), input.words());
        input_back
            .read(&input.header(), &words)
            .expect("well formed");
        assert_eq!(input_back, input, "input {k}");
    }
}

/// A header whose counts the words do not match is refused with both
/// lengths, its header fields kept (the server names the controller),
/// also for counts whose word total overflows.
#[test]
fn counts_that_do_not_match_the_words_are_refused() {
    let f = state(1, 2, 1, 3);
    let mut words = Vec::new();
    f.encode(&mut words);
    let mut h = f.header();
    h.contacts_carried += 1;
    let err = StateFrame::decode(&h, &words).unwrap_err();
    assert_eq!(
        err,
        WireError::Length {
            what: "state frame",
            expected: words.len() + CONTACT_WORDS,
            got: words.len()
        }
    );
    h.body_count = u32::MAX;
    h.contacts_carried = u32::MAX;
    assert!(StateFrame::decode(&h, &words).is_err());

    let mut input = InputFrame {
        controller_id: 5,
        step: 9,
        ..InputFrame::default()
    };
    input.push_torque(0, [1.0; 3]);
    let mut words = Vec::new();
    input.encode(&mut words);
    let mut h = input.header();
    h.torque_count = 1000;
    let mut back = InputFrame::default();
    assert!(back.read(&h, &words).is_err());
    assert_eq!((back.controller_id, back.step), (5, 9));
    assert!(back.torques.is_empty());
}

/// On a little-endian machine an entry's words are the bytes of its
/// `#[repr(C)]` struct, which is what lets C and Python readers view
/// the payload as arrays of them (protocol.md).
#[test]
fn an_entrys_words_are_its_structs_bytes() {
    let c = ContactFrame {
        body_a: 1,
        kind_b: CONTACT_PLANE,
        index_b: 2,
        id: 3,
        normal: [0.5, -1.0, 2.0],
        friction: [4.0, 0.0, -0.0],
    };
    let mut words = Vec::new();
    c.encode(&mut words);
    let mut bytes = Vec::new();
    for v in [c.body_a, c.kind_b, c.index_b, c.id] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for v in c.normal.iter().chain(&c.friction) {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let from_words: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    assert_eq!(from_words, bytes);
    assert_eq!(size_of::<ContactFrame>(), bytes.len());
}

// The sizes docs/protocol.md states: a change here is a protocol change.
#[test]
fn layouts_match_the_protocol_document() {
    assert_eq!(size_of::<BodyFrame>(), 8 * BODY_WORDS);
    assert_eq!(
        size_of::<[f64; 3]>() + size_of::<[f64; 2]>(),
        8 * JOINT_WORDS
    );
    assert_eq!(size_of::<ContactFrame>(), 8 * CONTACT_WORDS);
    assert_eq!(size_of::<JointTorque>(), 8 * TORQUE_WORDS);
    assert_eq!(size_of::<BodyImpulse>(), 8 * IMPULSE_WORDS);
    assert_eq!(size_of::<ControllerSlot>(), 24);
    assert_eq!(size_of::<StateHeader>(), 88 + 24 * MAX_CONTROLLERS);
    assert_eq!(size_of::<MotorTarget>(), 8 * MOTOR_WORDS);
    assert_eq!(size_of::<InputHeader>(), 40);
    assert_eq!(size_of::<ControlRequest>(), 48);
    assert_eq!(size_of::<ControlResponse>(), 80 + MESSAGE_LEN);
    for a in [
        align_of::<StateHeader>(),
        align_of::<InputHeader>(),
        align_of::<ControlRequest>(),
        align_of::<ControlResponse>(),
    ] {
        assert_eq!(a, 8);
    }
}

#[test]
fn a_big_scenes_state_buffer_fits_the_stream_budget() {
    assert_eq!(
        services::state_buffer(state_words(2, 1, 7)),
        services::MAX_STATE_BUFFER
    );
    let big = state_words(4000, 0, contact_capacity(4000, usize::MAX));
    let n = services::state_buffer(big);
    assert!((2..16).contains(&n), "{n}");
    assert!(
        n * services::MAX_STATE_SUBSCRIBERS * 8 * big <= services::STATE_STREAM_BYTES,
        "{n}"
    );
}

#[test]
fn type_names_carry_the_version() {
    use iceoryx2::prelude::ZeroCopySend;
    // SAFETY: type_name only returns the static name given by the derive.
    let names = unsafe {
        [
            StateHeader::type_name(),
            InputHeader::type_name(),
            ControlRequest::type_name(),
            ControlResponse::type_name(),
        ]
    };
    for n in names {
        assert!(
            n.starts_with("cosim::") && n.ends_with(&format!(".v{PROTOCOL_VERSION}")),
            "{n}"
        );
    }
}

#[test]
fn message_is_cut_at_a_character_boundary() {
    let mut r = ControlResponse::default();
    let long = "é".repeat(100);
    r.set_message(&long);
    assert_eq!(r.message().chars().count(), MESSAGE_LEN / 2);
    r.set_message("ok");
    assert_eq!(r.message(), "ok");
}

#[test]
fn server_names_come_back_from_control_services() {
    assert_eq!(services::server_of(&services::control("lab")), Some("lab"));
    assert_eq!(services::server_of(&services::state("lab")), None);
}
