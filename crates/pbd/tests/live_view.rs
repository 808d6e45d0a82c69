//! The live view: a Foxglove WebSocket client on 127.0.0.1 sees the log's channels and receives
//! `/tf`, and the latched `/scene` and `/robot` once when it subscribes (written before it joined),
//! then only when they are written again.

use std::collections::HashMap;
use std::net::TcpStream;
use std::time::Duration;

use dexter_sim::physics::{DexterSim, SimSettings};
use dexter_sim::scene::Scene;
use pbd::live::LiveView;
use pbd::mcap_log::{McapLog, TOPIC_ROBOT, TOPIC_SCENE, TOPIC_TF};
use serde_json::Value;
use tungstenite::client::IntoClientRequest;
use tungstenite::http::HeaderValue;
use tungstenite::stream::MaybeTlsStream;
use tungstenite::{Message, WebSocket};

type Client = WebSocket<MaybeTlsStream<TcpStream>>;

fn connect(live: &LiveView) -> Client {
    let mut request = live.url().into_client_request().unwrap();
    request
        .headers_mut()
        .insert("Sec-WebSocket-Protocol", HeaderValue::from_static("foxglove.sdk.v1"));
    let (client, response) = tungstenite::connect(request).expect("the live view accepts a client");
    assert_eq!(
        response
            .headers()
            .get("Sec-WebSocket-Protocol")
            .map(|v| v.to_str().unwrap()),
        Some("foxglove.sdk.v1")
    );
    if let MaybeTlsStream::Plain(s) = client.get_ref() {
        s.set_read_timeout(Some(Duration::from_millis(50))).unwrap();
    }
    client
}

/// Reads for 300 ms, as a viewer does; text messages are parsed, binary
/// message-data frames (opcode 1, subscription id, log time, payload) are counted by subscription.
fn drain(client: &mut Client, texts: &mut Vec<Value>, counts: &mut HashMap<u32, usize>) {
    drain_for(client, texts, counts, Duration::from_millis(300));
}

/// [`drain`] for `duration`.
fn drain_for(client: &mut Client, texts: &mut Vec<Value>, counts: &mut HashMap<u32, usize>, duration: Duration) {
    let until = std::time::Instant::now() + duration;
    while std::time::Instant::now() < until {
        match client.read() {
            Ok(Message::Text(t)) => texts.push(serde_json::from_str(&t).unwrap()),
            Ok(Message::Binary(b)) => {
                assert_eq!(b[0], 1, "message data");
                let sub = u32::from_le_bytes(b[1..5].try_into().unwrap());
                if sub == 0 {
                    // /tf: the log's foxglove.FrameTransforms, Protobuf.
                    pbd::mcap_log::message_json("foxglove.FrameTransforms", "protobuf", &b[13..])
                        .expect("the payload is the log's message");
                }
                *counts.entry(sub).or_default() += 1;
            }
            Ok(_) => {}
            Err(tungstenite::Error::Io(e))
                if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) =>
            {
                continue;
            }
            Err(e) => panic!("{e}"),
        }
    }
}

#[test]
fn a_foxglove_client_watches_the_run_as_it_is_logged() {
    let subscribe_all = |client: &mut Client, texts: &[Value]| {
        let channels: HashMap<String, u64> = texts
            .iter()
            .filter(|t| t["op"] == "advertise")
            .flat_map(|t| t["channels"].as_array().unwrap().clone())
            .map(|c| (c["topic"].as_str().unwrap().to_owned(), c["id"].as_u64().unwrap()))
            .collect();
        for t in [TOPIC_TF, TOPIC_SCENE, TOPIC_ROBOT] {
            assert!(channels.contains_key(t), "{t} advertised: {channels:?}");
        }
        let subscriptions: Vec<Value> = [TOPIC_TF, TOPIC_SCENE, TOPIC_ROBOT]
            .iter()
            .enumerate()
            .map(|(i, t)| serde_json::json!({ "id": i, "channelId": channels[*t] }))
            .collect();
        let subscribe = serde_json::json!({ "op": "subscribe", "subscriptions": subscriptions });
        client.send(Message::text(subscribe.to_string())).unwrap();
    };
    let live = LiveView::start("127.0.0.1:0").unwrap();
    assert!(live.url().starts_with("ws://127.0.0.1:"));
    let scene = Scene::builtin("sorting").unwrap();
    let sim = DexterSim::new(&scene, SimSettings::default()).unwrap();
    let path = std::env::temp_dir().join(format!("pbd-live-{}.mcap", std::process::id()));
    let mut log = McapLog::create(&path).unwrap();
    log.stream_to(live.clone()).unwrap();
    log.log_scene(&scene, sim.header(), 0.0).unwrap();
    log.log_robot(sim.model(), 0.0).unwrap();

    // A client that joins after the robot and the scene were written.
    let mut client = connect(&live);
    let (mut texts, mut counts) = (Vec::new(), HashMap::new());
    drain(&mut client, &mut texts, &mut counts);
    subscribe_all(&mut client, &texts);
    drain(&mut client, &mut texts, &mut counts);
    // The robot and the scene at once, once.
    for (sub, topic) in [(1, TOPIC_SCENE), (2, TOPIC_ROBOT)] {
        assert_eq!(counts.get(&sub).copied(), Some(1), "{topic}: {counts:?}");
    }

    // 20 snapshots a second of simulated time apart (each a /tf keyframe), the client reading for
    // 50 ms after each.
    let header = sim.header().clone();
    let mut snap = sim.snapshot("");
    for i in 0..20 {
        snap.time = f64::from(i);
        log.log_snapshot(&header, &snap).unwrap();
        drain_for(&mut client, &mut texts, &mut counts, Duration::from_millis(50));
    }
    drain(&mut client, &mut texts, &mut counts);
    // A second viewer joins late: it too gets the robot and the scene once; the first gets nothing more.
    let mut second = connect(&live);
    let (mut texts2, mut counts2) = (Vec::new(), HashMap::new());
    drain(&mut second, &mut texts2, &mut counts2);
    subscribe_all(&mut second, &texts2);
    drain(&mut second, &mut texts2, &mut counts2);
    for (sub, topic) in [(1, TOPIC_SCENE), (2, TOPIC_ROBOT)] {
        assert_eq!(
            counts2.get(&sub).copied(),
            Some(1),
            "{topic}, second viewer: {counts2:?}"
        );
    }
    // A new scene (the next run) reaches both, once.
    log.log_scene(&scene, sim.header(), 20.0).unwrap();
    drain(&mut client, &mut texts, &mut counts);
    drain(&mut second, &mut texts2, &mut counts2);
    assert_eq!(counts.get(&1).copied(), Some(2), "{counts:?}");
    assert_eq!(counts2.get(&1).copied(), Some(2), "{counts2:?}");
    log.finish().unwrap();
    let _ = std::fs::remove_file(&path);

    assert_eq!(
        counts.get(&0).copied().unwrap_or(0),
        20,
        "every /tf message: {counts:?}"
    );
    assert_eq!(counts.get(&2).copied(), Some(1), "/robot once: {counts:?}");
    assert_eq!(live.clients(), 2);
}

#[test]
fn a_bad_bind_address_is_refused_with_a_message() {
    for bad in ["nonsense", "127.0.0.1:99999", ":8765", "127.0.0.1:"] {
        let e = LiveView::start(bad).unwrap_err();
        assert!(format!("{e:#}").contains(bad), "{bad}: {e:#}");
    }
}

#[test]
fn live_options_are_one_setting_read_from_an_address_or_a_table() {
    use pbd::LiveOptions;
    let from = |json: &str| serde_json::from_str::<LiveOptions>(json).unwrap();
    assert_eq!(
        from("\"127.0.0.1:8765\""),
        LiveOptions::bind(Some("127.0.0.1:8765".into()))
    );
    assert_eq!(
        from("{\"bind\": \"0.0.0.0:9000\"}").bind.as_deref(),
        Some("0.0.0.0:9000")
    );
    assert_eq!(from("null"), LiveOptions::default());
    assert!(!LiveOptions::default().is_on());
    // A record's options without the key: no listener; a running view is never serialised.
    let o: pbd::RecordOptions = serde_json::from_str("{}").unwrap();
    assert!(!o.live.is_on());
    let live = pbd::LiveView::start("127.0.0.1:0").unwrap();
    let shared = LiveOptions::view(&live);
    assert!(shared.is_on() && shared.start().unwrap() == Some(live.clone()));
    assert_eq!(
        serde_json::to_value(&shared).unwrap(),
        serde_json::json!({ "bind": null })
    );
}
