//! Little-endian field reading shared by the binary readers.

/// Sequential little-endian reader over one fixed-size record.
pub(crate) struct Rec<'a> {
    bytes: &'a [u8],
    pub(crate) pos: usize,
}

impl<'a> Rec<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, pos: 0 }
    }

    /// Next `N` bytes. Callers check record sizes before reading fields, so a short read is a programming error; it yields zeros rather than panicking.
    pub(crate) fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0; N];
        if let Some(src) = self.bytes.get(self.pos..self.pos + N) {
            out.copy_from_slice(src);
        }
        self.pos += N;
        out
    }

    pub(crate) fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take())
    }

    pub(crate) fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }

    pub(crate) fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }

    pub(crate) fn i16(&mut self) -> i16 {
        i16::from_le_bytes(self.take())
    }

    pub(crate) fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }

    pub(crate) fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }

    pub(crate) fn vec3(&mut self) -> [f32; 3] {
        [self.f32(), self.f32(), self.f32()]
    }

    pub(crate) fn vec3_i16(&mut self) -> [f32; 3] {
        [f32::from(self.i16()), f32::from(self.i16()), f32::from(self.i16())]
    }
}
