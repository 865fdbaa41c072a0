//! The map's change events, for every adapter that streams them (zenoh's
//! `opengraph/<map>/events`): the live build's commits and the service's own writes
//! (`update_map`, `undo_map_edit`, `write_cypher`), numbered consecutively so a subscriber
//! can tell whether it missed one.

use std::sync::{Mutex, PoisonError};

pub use ingest::build::{MapEvent, MapEventKind};

/// Events waiting for a slow subscriber at most; a subscriber further behind misses some
/// (and sees the gap in `seq`).
pub const BACKLOG: usize = 1024;

/// The service's event bus.
#[derive(Debug)]
pub struct EventBus {
    sender: tokio::sync::broadcast::Sender<MapEvent>,
    seq: Mutex<u64>,
}

impl Default for EventBus {
    fn default() -> Self {
        EventBus {
            sender: tokio::sync::broadcast::channel(BACKLOG).0,
            seq: Mutex::new(0),
        }
    }
}

impl EventBus {
    /// Numbers `event` (the next `seq`, from 1) and sends it to every subscriber; returns
    /// the numbered event.
    pub fn emit(&self, mut event: MapEvent) -> MapEvent {
        // numbering and sending under one lock keeps the stream in order
        let mut seq = self.seq.lock().unwrap_or_else(PoisonError::into_inner);
        *seq += 1;
        event.seq = *seq;
        let _ = self.sender.send(event.clone());
        event
    }

    /// A new subscriber: it receives the events emitted from now on.
    pub fn subscribe(&self) -> tokio::sync::broadcast::Receiver<MapEvent> {
        self.sender.subscribe()
    }

    /// The event a successful write tool's `answer` makes, if it changed the map.
    pub fn of_tool(name: &str, answer: &serde_json::Value, commit: u64) -> Option<MapEvent> {
        let id = |v: &serde_json::Value| v.as_u64();
        let (kind, ids) = match name {
            "update_map" => {
                let applied = answer.get("applied").filter(|a| !a.is_null())?;
                // the edit node and every node it made, deleted or changed
                let mut ids: Vec<u64> = applied.get("edit_id").and_then(id).into_iter().collect();
                for k in ["created_nodes", "deleted_nodes", "changed_nodes"] {
                    if let Some(v) = applied.get(k).and_then(|v| v.as_array()) {
                        ids.extend(v.iter().filter_map(id));
                    }
                }
                (MapEventKind::EditApplied, ids)
            }
            "undo_map_edit" => (
                MapEventKind::EditUndone,
                answer.get("edit_id").and_then(id).into_iter().collect(),
            ),
            "write_cypher" => (MapEventKind::CypherWrite, Vec::new()),
            _ => return None,
        };
        let mut ids = ids;
        ids.sort_unstable();
        ids.dedup();
        Some(MapEvent {
            seq: 0,
            commit,
            kind,
            ids,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn events_are_numbered_in_order() {
        let bus = EventBus::default();
        let mut rx = bus.subscribe();
        for _ in 0..3 {
            bus.emit(MapEvent {
                seq: 0,
                commit: 7,
                kind: MapEventKind::CypherWrite,
                ids: vec![],
            });
        }
        let seqs: Vec<u64> = (0..3).map(|_| rx.try_recv().unwrap().seq).collect();
        assert_eq!(seqs, vec![1, 2, 3]);
        assert!(EventBus::of_tool("read_cypher", &serde_json::json!({}), 1).is_none());
        let e = EventBus::of_tool("update_map", &serde_json::json!({"applied": null}), 1);
        assert!(e.is_none(), "a proposal changes nothing");
    }
}
