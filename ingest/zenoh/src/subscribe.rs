//! The sensor subscribers: one zenoh subscriber per configured topic, each handing its
//! samples of the topic's type to the live input ([`ingest::sources::live::LiveInput::accept`]),
//! which decodes, checks and assembles them, and counting those of another type
//! ([`ingest::sources::live::LiveInput::refuse_type`]). Nothing here can fail on a sample.

use std::sync::Arc;

use ingest::sources::live::{LiveConfig, LiveInput, MessageKind};
use zenoh::Wait;

use crate::{Result, keys, zerr};

/// The subscribers; dropping this undeclares them.
pub struct Subscriptions {
    subscribers: Vec<zenoh::pubsub::Subscriber<()>>,
    /// The key expressions subscribed to.
    pub keys: Vec<String>,
}

impl std::fmt::Debug for Subscriptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Subscriptions")
            .field("keys", &self.keys)
            .field("subscribers", &self.subscribers.len())
            .finish()
    }
}

/// Subscribes to every topic of `cfg` on `session`, feeding `input`.
///
/// # Errors
/// [`crate::Error::Zenoh`] when a subscriber cannot be declared.
pub fn subscribe(
    session: &zenoh::Session,
    cfg: &LiveConfig,
    input: Arc<LiveInput>,
) -> Result<Subscriptions> {
    let mut subscribers = Vec::new();
    let mut keys_out = Vec::new();
    for kind in MessageKind::ALL {
        let Some(topic) = kind.topic(cfg) else {
            continue;
        };
        let key = keys::ros_subscription(cfg.domain_id, topic);
        let input = input.clone();
        let (domain, topic) = (cfg.domain_id, topic.to_string());
        let want = kind.ros_type().dds;
        let sub = session
            .declare_subscriber(key.clone())
            .callback(move |sample: zenoh::sample::Sample| {
                let key = sample.key_expr().as_str();
                match keys::ros_type_of(key, domain, &topic) {
                    Some(ty) if ty == want => {
                        input.accept(kind, key, &sample.payload().to_bytes());
                    }
                    other => input.refuse_type(kind, key, other.unwrap_or("?")),
                }
            })
            .wait()
            .map_err(zerr)?;
        subscribers.push(sub);
        keys_out.push(key);
    }
    Ok(Subscriptions {
        subscribers,
        keys: keys_out,
    })
}
