//! Read-only opens: the file's bytes never change, a file without write permission opens,
//! several read-only handles read at once, a writer elsewhere is named, and writes through a
//! read-only handle are refused with the store unchanged.

use graphstore::{Error, GraphRead, Store, Value};
use scene::opengraph_schema;

fn sha(path: &std::path::Path) -> Vec<u8> {
    std::fs::read(path).unwrap()
}

fn make(dir: &std::path::Path) -> std::path::PathBuf {
    let p = dir.join("s.og");
    let s = Store::create(&p).unwrap();
    s.set_schema(opengraph_schema()).unwrap();
    s.write(|tx| {
        for i in 0..50 {
            tx.create_node_named(&["Thing"], &[("n", Value::Int(i))])?;
        }
        Ok(())
    })
    .unwrap();
    drop(s);
    p
}

#[test]
fn read_only_opens_never_change_the_file_and_share_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = make(dir.path());
    let before = sha(&p);
    // no write permission on the file
    let mut perm = std::fs::metadata(&p).unwrap().permissions();
    perm.set_readonly(true);
    std::fs::set_permissions(&p, perm).unwrap();
    let a = Store::open_read_only(&p).unwrap();
    let b = Store::open_read_only(&p).unwrap();
    assert!(a.is_read_only() && b.is_read_only());
    assert_eq!(
        a.read().unwrap().nodes_with_label("Thing").unwrap().len(),
        50
    );
    assert_eq!(b.counts().unwrap().nodes.get("Thing"), Some(&50));
    let q = a
        .query(
            "MATCH (t:Thing) RETURN count(t) AS n",
            &graphstore::cypher::QueryOptions::default(),
        )
        .unwrap();
    assert_eq!(q.rows.len(), 1);
    // writes are refused, by the API and by Cypher
    let e = a
        .write(|tx| tx.create_node_named(&["Thing"], &[]))
        .unwrap_err();
    assert!(matches!(e, Error::ReadOnlyStore { .. }), "{e}");
    assert!(
        a.query(
            "CREATE (:Thing)",
            &graphstore::cypher::QueryOptions::default()
        )
        .is_err()
    );
    drop((a, b));
    assert_eq!(sha(&p), before, "a read-only open changed the file");
    let mut perm = std::fs::metadata(&p).unwrap().permissions();
    #[allow(clippy::permissions_set_readonly_false)]
    perm.set_readonly(false);
    std::fs::set_permissions(&p, perm).unwrap();
}

#[test]
fn a_writer_elsewhere_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let p = make(dir.path());
    let w = Store::open(&p).unwrap();
    let e = Store::open_read_only(&p).unwrap_err();
    assert!(matches!(e, Error::InUse { .. }), "{e}");
    assert!(
        e.to_string()
            .contains("open for writing by another process"),
        "{e}"
    );
    drop(w);
    assert!(Store::open_read_only(&p).is_ok());
    let e = Store::open_read_only(dir.path().join("missing.og")).unwrap_err();
    assert!(e.to_string().contains("no such file"), "{e}");
}
