//! An SDO server (expedited and segmented, any length up to [`SdoServer::MAX_DOWNLOAD`]) over
//! whatever answers [`ObjectAccess`]. Correct toggles, sizes and abort codes; block transfer
//! is answered with abort 0x05040001.
//!
//! Not canopen-rs 0.6.1's `SdoServer`: its transfers are capped at 32 bytes (datatypes.rs
//! ~29), it cannot answer the mapping codes 0x06040041/42/43 or 0x08000022 that the remap
//! rules need, and it serves its own dictionary type rather than a device's rules.

use crate::wire::{AbortCode, ExpeditedData, InitiateKind, SdoRequest, SdoResponse, SdoSegment};

/// What the SDO server reads and writes: the device's object dictionary plus its rules.
pub trait ObjectAccess {
    /// The bytes of (index, sub) for an upload.
    fn upload(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode>;
    /// Checks that (index, sub) exists and may be written, before a segmented download
    /// starts; returns the fixed size of its type, if it has one.
    fn download_check(&mut self, index: u16, sub: u8) -> Result<Option<usize>, AbortCode>;
    /// Stores `data` at (index, sub).
    fn download(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode>;
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Transfer {
    Idle,
    Upload {
        index: u16,
        sub: u8,
        data: Vec<u8>,
        pos: usize,
        toggle: bool,
    },
    Download {
        index: u16,
        sub: u8,
        data: Vec<u8>,
        size: Option<u32>,
        toggle: bool,
    },
}

/// The server's transfer state.
#[derive(Clone, Debug)]
pub struct SdoServer {
    transfer: Transfer,
    aborts_sent: u64,
}

impl Default for SdoServer {
    fn default() -> Self {
        Self::new()
    }
}

impl SdoServer {
    /// Largest segmented download accepted (larger: abort 0x05040005 out of memory).
    pub const MAX_DOWNLOAD: usize = 64 * 1024;

    /// An idle server.
    pub fn new() -> SdoServer {
        SdoServer {
            transfer: Transfer::Idle,
            aborts_sent: 0,
        }
    }

    /// Aborts this server has sent.
    pub fn aborts_sent(&self) -> u64 {
        self.aborts_sent
    }

    /// Whether a segmented transfer is in progress.
    pub fn busy(&self) -> bool {
        self.transfer != Transfer::Idle
    }

    /// Drops any transfer in progress (NMT reset, timeout).
    pub fn reset(&mut self) {
        self.transfer = Transfer::Idle;
    }

    fn abort(&mut self, index: u16, sub: u8, code: AbortCode) -> Option<SdoResponse> {
        self.transfer = Transfer::Idle;
        self.aborts_sent += 1;
        Some(SdoResponse::Abort { index, sub, code })
    }

    /// A request that did not parse (unknown command specifier, block transfer): abort
    /// 0x05040001 naming the multiplexer bytes of the frame.
    pub fn handle_unparsable(&mut self, data: &[u8]) -> Option<SdoResponse> {
        let (index, sub) = if data.len() >= 4 {
            (u16::from_le_bytes([data[1], data[2]]), data[3])
        } else {
            (0, 0)
        };
        self.abort(index, sub, AbortCode::BadCommand)
    }

    /// Handles one request; returns the response to send (none after a client abort).
    pub fn handle(&mut self, req: SdoRequest, od: &mut dyn ObjectAccess) -> Option<SdoResponse> {
        match req {
            SdoRequest::Abort { .. } => {
                self.transfer = Transfer::Idle;
                None
            }
            SdoRequest::InitiateUpload { index, sub } => self.initiate_upload(index, sub, od),
            SdoRequest::UploadSegment { toggle } => self.upload_segment(toggle),
            SdoRequest::InitiateDownload { index, sub, kind } => {
                self.transfer = Transfer::Idle;
                match kind {
                    InitiateKind::Expedited(e) => self.expedited_download(index, sub, e, od),
                    InitiateKind::Segmented { size } => {
                        self.initiate_segmented_download(index, sub, size, od)
                    }
                }
            }
            SdoRequest::DownloadSegment(seg) => self.download_segment(seg, od),
        }
    }

    /// Reads the object: expedited when it fits in four bytes, else starts a segmented upload.
    fn initiate_upload(
        &mut self,
        index: u16,
        sub: u8,
        od: &mut dyn ObjectAccess,
    ) -> Option<SdoResponse> {
        self.transfer = Transfer::Idle;
        let data = match od.upload(index, sub) {
            Ok(d) => d,
            Err(code) => return self.abort(index, sub, code),
        };
        if !data.is_empty() && data.len() <= 4 {
            let e = ExpeditedData::new(&data).ok()?;
            Some(SdoResponse::InitiateUpload {
                index,
                sub,
                kind: InitiateKind::Expedited(e),
            })
        } else {
            let size = u32::try_from(data.len()).unwrap_or(u32::MAX);
            self.transfer = Transfer::Upload {
                index,
                sub,
                data,
                pos: 0,
                toggle: false,
            };
            Some(SdoResponse::InitiateUpload {
                index,
                sub,
                kind: InitiateKind::Segmented { size: Some(size) },
            })
        }
    }

    /// The next (at most seven-byte) segment of the upload under way.
    fn upload_segment(&mut self, toggle: bool) -> Option<SdoResponse> {
        let Transfer::Upload {
            index,
            sub,
            data,
            pos,
            toggle: expected,
        } = &mut self.transfer
        else {
            return self.abort(0, 0, AbortCode::BadCommand);
        };
        let (index, sub) = (*index, *sub);
        if toggle != *expected {
            return self.abort(index, sub, AbortCode::ToggleNotAlternated);
        }
        let end = (*pos + 7).min(data.len());
        let last = end == data.len();
        let seg = SdoSegment::new(toggle, last, &data[*pos..end]).ok()?;
        *pos = end;
        *expected = !toggle;
        if last {
            self.transfer = Transfer::Idle;
        }
        Some(SdoResponse::UploadSegment(seg))
    }

    /// Writes an expedited (at most four-byte) download.
    fn expedited_download(
        &mut self,
        index: u16,
        sub: u8,
        e: ExpeditedData,
        od: &mut dyn ObjectAccess,
    ) -> Option<SdoResponse> {
        let bytes = match e.size() {
            Some(_) => e.bytes(),
            // No size: the type says how many of the four bytes count.
            None => match od.download_check(index, sub) {
                Ok(Some(n)) if n <= 4 => &e.bytes()[..n],
                Ok(_) => e.bytes(),
                Err(code) => return self.abort(index, sub, code),
            },
        };
        match od.download(index, sub, bytes) {
            Ok(()) => Some(SdoResponse::InitiateDownload { index, sub }),
            Err(code) => self.abort(index, sub, code),
        }
    }

    /// Starts a segmented download after checking the announced size against the object.
    fn initiate_segmented_download(
        &mut self,
        index: u16,
        sub: u8,
        size: Option<u32>,
        od: &mut dyn ObjectAccess,
    ) -> Option<SdoResponse> {
        let fixed = match od.download_check(index, sub) {
            Ok(f) => f,
            Err(code) => return self.abort(index, sub, code),
        };
        if let Some(s) = size {
            if s as usize > Self::MAX_DOWNLOAD {
                return self.abort(index, sub, AbortCode::OutOfMemory);
            }
            if let Some(n) = fixed {
                if s as usize > n {
                    return self.abort(index, sub, AbortCode::LengthTooHigh);
                }
                if (s as usize) < n {
                    return self.abort(index, sub, AbortCode::LengthTooLow);
                }
            }
        }
        self.transfer = Transfer::Download {
            index,
            sub,
            data: Vec::new(),
            size,
            toggle: false,
        };
        Some(SdoResponse::InitiateDownload { index, sub })
    }

    /// Appends one segment of the download under way; writes the object after the last.
    fn download_segment(
        &mut self,
        seg: SdoSegment,
        od: &mut dyn ObjectAccess,
    ) -> Option<SdoResponse> {
        let Transfer::Download {
            index,
            sub,
            data,
            size,
            toggle,
        } = &mut self.transfer
        else {
            return self.abort(0, 0, AbortCode::BadCommand);
        };
        let (index, sub, size) = (*index, *sub, *size);
        if seg.toggle != *toggle {
            return self.abort(index, sub, AbortCode::ToggleNotAlternated);
        }
        if data.len() + seg.data().len() > Self::MAX_DOWNLOAD {
            return self.abort(index, sub, AbortCode::OutOfMemory);
        }
        data.extend_from_slice(seg.data());
        *toggle = !*toggle;
        if size.is_some_and(|s| data.len() > s as usize) {
            return self.abort(index, sub, AbortCode::LengthTooHigh);
        }
        if !seg.last {
            return Some(SdoResponse::DownloadSegment { toggle: seg.toggle });
        }
        let data = std::mem::take(data);
        self.transfer = Transfer::Idle;
        if size.is_some_and(|s| data.len() < s as usize) {
            return self.abort(index, sub, AbortCode::LengthTooLow);
        }
        match od.download(index, sub, &data) {
            Ok(()) => Some(SdoResponse::DownloadSegment { toggle: seg.toggle }),
            Err(code) => self.abort(index, sub, code),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    /// (index, sub) → bytes; 0x2000 is a UINT16, 0x3000 read-only, anything else missing.
    #[derive(Default)]
    struct Map(BTreeMap<(u16, u8), Vec<u8>>);
    impl ObjectAccess for Map {
        fn upload(&mut self, index: u16, sub: u8) -> Result<Vec<u8>, AbortCode> {
            self.0
                .get(&(index, sub))
                .cloned()
                .ok_or(AbortCode::NoObject)
        }
        fn download_check(&mut self, index: u16, sub: u8) -> Result<Option<usize>, AbortCode> {
            match (index, sub) {
                (0x3000, _) => Err(AbortCode::WriteReadOnly),
                (0x2000, 0) => Ok(Some(2)),
                (0x1008, 0) => Ok(None),
                _ => Err(AbortCode::NoObject),
            }
        }
        fn download(&mut self, index: u16, sub: u8, data: &[u8]) -> Result<(), AbortCode> {
            let fixed = self.download_check(index, sub)?;
            if fixed.is_some_and(|n| n != data.len()) {
                return Err(AbortCode::LengthMismatch);
            }
            self.0.insert((index, sub), data.to_vec());
            Ok(())
        }
    }

    fn exp(d: &[u8]) -> InitiateKind {
        InitiateKind::Expedited(ExpeditedData::new(d).unwrap())
    }

    #[test]
    fn expedited_write_read_and_unsized_write() {
        let mut s = SdoServer::new();
        let mut od = Map::default();
        let r = s.handle(
            SdoRequest::InitiateDownload {
                index: 0x2000,
                sub: 0,
                kind: exp(&[1, 2]),
            },
            &mut od,
        );
        assert_eq!(
            r,
            Some(SdoResponse::InitiateDownload {
                index: 0x2000,
                sub: 0
            })
        );
        let r = s.handle(
            SdoRequest::InitiateUpload {
                index: 0x2000,
                sub: 0,
            },
            &mut od,
        );
        assert_eq!(
            r,
            Some(SdoResponse::InitiateUpload {
                index: 0x2000,
                sub: 0,
                kind: exp(&[1, 2])
            })
        );
        // 0x22: four bytes, no size → the UINT16's two bytes are taken.
        let k = InitiateKind::Expedited(ExpeditedData::without_size([7, 8, 9, 9]));
        s.handle(
            SdoRequest::InitiateDownload {
                index: 0x2000,
                sub: 0,
                kind: k,
            },
            &mut od,
        );
        assert_eq!(od.0[&(0x2000, 0)], vec![7, 8]);
        let r = s.handle(
            SdoRequest::InitiateDownload {
                index: 0x2000,
                sub: 0,
                kind: exp(&[1]),
            },
            &mut od,
        );
        assert_eq!(r, abort(0x2000, AbortCode::LengthMismatch));
        let r = s.handle(
            SdoRequest::InitiateUpload {
                index: 0x4000,
                sub: 1,
            },
            &mut od,
        );
        assert_eq!(
            r,
            Some(SdoResponse::Abort {
                index: 0x4000,
                sub: 1,
                code: AbortCode::NoObject
            })
        );
        assert_eq!(s.aborts_sent(), 2);
    }

    fn download(
        s: &mut SdoServer,
        od: &mut Map,
        payload: &[u8],
        size: Option<u32>,
    ) -> Option<SdoResponse> {
        let r = s.handle(
            SdoRequest::InitiateDownload {
                index: 0x1008,
                sub: 0,
                kind: InitiateKind::Segmented { size },
            },
            od,
        );
        assert_eq!(
            r,
            Some(SdoResponse::InitiateDownload {
                index: 0x1008,
                sub: 0
            })
        );
        let mut toggle = false;
        let chunks: Vec<_> = payload.chunks(7).collect();
        let n = chunks.len().max(1);
        let mut last = None;
        for i in 0..n {
            let c = chunks.get(i).copied().unwrap_or(&[]);
            let seg = SdoSegment::new(toggle, i + 1 == n, c).unwrap();
            last = s.handle(SdoRequest::DownloadSegment(seg), od);
            if let Some(SdoResponse::Abort { .. }) = last {
                return last;
            }
            assert_eq!(last, Some(SdoResponse::DownloadSegment { toggle }));
            toggle = !toggle;
        }
        last
    }

    fn upload(s: &mut SdoServer, od: &mut Map, index: u16) -> Vec<u8> {
        let r = s
            .handle(SdoRequest::InitiateUpload { index, sub: 0 }, od)
            .unwrap();
        let size = match r {
            SdoResponse::InitiateUpload {
                kind: InitiateKind::Segmented { size: Some(n) },
                ..
            } => n as usize,
            SdoResponse::InitiateUpload {
                kind: InitiateKind::Expedited(e),
                ..
            } => return e.bytes().to_vec(),
            other => panic!("{other:?}"),
        };
        let mut out = vec![];
        let mut toggle = false;
        loop {
            match s.handle(SdoRequest::UploadSegment { toggle }, od) {
                Some(SdoResponse::UploadSegment(seg)) => {
                    assert_eq!(seg.toggle, toggle);
                    out.extend_from_slice(seg.data());
                    if seg.last {
                        break;
                    }
                }
                other => panic!("{other:?}"),
            }
            toggle = !toggle;
        }
        assert_eq!(out.len(), size);
        out
    }

    #[test]
    fn segmented_any_length_round_trips() {
        for len in [0usize, 1, 4, 5, 6, 7, 8, 13, 14, 15, 32, 33, 100, 1000] {
            let mut s = SdoServer::new();
            let mut od = Map::default();
            let payload: Vec<u8> = (0..len).map(|i| (i * 7 + 1) as u8).collect();
            for size in [Some(len as u32), None] {
                download(&mut s, &mut od, &payload, size);
                assert_eq!(od.0[&(0x1008, 0)], payload);
                assert_eq!(upload(&mut s, &mut od, 0x1008), payload, "{len}");
                assert!(!s.busy());
            }
        }
    }

    /// The abort the server answers with for sub-index 0 of `index`.
    fn abort(index: u16, code: AbortCode) -> Option<SdoResponse> {
        Some(SdoResponse::Abort {
            index,
            sub: 0,
            code,
        })
    }

    /// Starts a segmented download of `size` bytes to sub-index 0 of `index`.
    fn initiate_segmented(
        s: &mut SdoServer,
        od: &mut Map,
        index: u16,
        size: u32,
    ) -> Option<SdoResponse> {
        s.handle(
            SdoRequest::InitiateDownload {
                index,
                sub: 0,
                kind: InitiateKind::Segmented { size: Some(size) },
            },
            od,
        )
    }

    #[test]
    fn toggle_size_and_sequence_errors_abort() {
        let mut s = SdoServer::new();
        let mut od = Map::default();
        // Toggle wrong on the first download segment.
        initiate_segmented(&mut s, &mut od, 0x1008, 3);
        let r = s.handle(
            SdoRequest::DownloadSegment(SdoSegment::new(true, true, b"abc").unwrap()),
            &mut od,
        );
        assert_eq!(r, abort(0x1008, AbortCode::ToggleNotAlternated));
        assert!(!s.busy());
        // Size indicated 3, 5 bytes sent.
        let r = download(&mut s, &mut od, b"abcde", Some(3));
        assert_eq!(r, abort(0x1008, AbortCode::LengthTooHigh));
        // Size indicated 9, 5 bytes sent.
        let r = download(&mut s, &mut od, b"abcde", Some(9));
        assert_eq!(r, abort(0x1008, AbortCode::LengthTooLow));
        // Segment without a transfer.
        let r = s.handle(SdoRequest::UploadSegment { toggle: false }, &mut od);
        assert_eq!(r, abort(0, AbortCode::BadCommand));
        // Segmented download to a read-only or fixed-size object aborts at initiate.
        let r = initiate_segmented(&mut s, &mut od, 0x3000, 9);
        assert_eq!(r, abort(0x3000, AbortCode::WriteReadOnly));
        let r = initiate_segmented(&mut s, &mut od, 0x2000, 9);
        assert_eq!(r, abort(0x2000, AbortCode::LengthTooHigh));
        // Upload toggle error mid-transfer.
        od.0.insert((0x1008, 0), vec![1; 20]);
        s.handle(
            SdoRequest::InitiateUpload {
                index: 0x1008,
                sub: 0,
            },
            &mut od,
        );
        s.handle(SdoRequest::UploadSegment { toggle: false }, &mut od);
        let r = s.handle(SdoRequest::UploadSegment { toggle: false }, &mut od);
        assert_eq!(r, abort(0x1008, AbortCode::ToggleNotAlternated));
        // A client abort ends the transfer silently.
        s.handle(
            SdoRequest::InitiateUpload {
                index: 0x1008,
                sub: 0,
            },
            &mut od,
        );
        assert!(s.busy());
        assert_eq!(
            s.handle(
                SdoRequest::Abort {
                    index: 0x1008,
                    sub: 0,
                    code: AbortCode::Timeout
                },
                &mut od
            ),
            None
        );
        assert!(!s.busy());
        assert_eq!(
            s.handle_unparsable(&[0xC0, 0x08, 0x10, 0, 0, 0, 0, 0]),
            abort(0x1008, AbortCode::BadCommand)
        );
    }
}
