//! octowrap's cross-crate tests (in `tests/`): conformance of the readers against the shared
//! real data, and round trips through the readers and writers. The shared data is found through
//! `octowrap-testdata`.
