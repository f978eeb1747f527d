//! 8-bit grayscale frames: an owned image and a borrowed view with a row stride.

/// An owned 8-bit grayscale image, rows packed (stride = width).
#[derive(Clone, PartialEq, Eq)]
pub struct GrayImage {
    width: usize,
    height: usize,
    data: Vec<u8>,
}

impl std::fmt::Debug for GrayImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "GrayImage({}x{})", self.width, self.height)
    }
}

impl GrayImage {
    /// An image filled with `value`.
    pub fn filled(width: usize, height: usize, value: u8) -> Self {
        GrayImage {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// Wraps packed pixel data; `None` when `data.len() != width * height`.
    pub fn from_vec(width: usize, height: usize, data: Vec<u8>) -> Option<Self> {
        (data.len() == width * height).then_some(GrayImage {
            width,
            height,
            data,
        })
    }

    pub fn width(&self) -> usize {
        self.width
    }
    pub fn height(&self) -> usize {
        self.height
    }
    pub fn data(&self) -> &[u8] {
        &self.data
    }
    pub fn data_mut(&mut self) -> &mut [u8] {
        &mut self.data
    }
    pub fn into_vec(self) -> Vec<u8> {
        self.data
    }
    pub fn row(&self, y: usize) -> &[u8] {
        &self.data[y * self.width..(y + 1) * self.width]
    }
    pub fn row_mut(&mut self, y: usize) -> &mut [u8] {
        &mut self.data[y * self.width..(y + 1) * self.width]
    }
    pub fn get(&self, x: usize, y: usize) -> u8 {
        self.data[y * self.width + x]
    }
    pub fn view(&self) -> GrayView<'_> {
        GrayView {
            width: self.width,
            height: self.height,
            stride: self.width,
            data: &self.data,
        }
    }
}

/// A borrowed 8-bit grayscale image whose rows start `stride` bytes apart (camera buffers may pad
/// their rows).
#[derive(Clone, Copy, Debug)]
pub struct GrayView<'a> {
    width: usize,
    height: usize,
    stride: usize,
    data: &'a [u8],
}

impl<'a> GrayView<'a> {
    /// `None` when the buffer is too short for `height` rows of `stride` bytes or
    /// `stride < width`.
    pub fn new(width: usize, height: usize, stride: usize, data: &'a [u8]) -> Option<Self> {
        let need = if height == 0 {
            0
        } else {
            (height - 1) * stride + width
        };
        (stride >= width && data.len() >= need).then_some(GrayView {
            width,
            height,
            stride,
            data,
        })
    }
    pub fn width(&self) -> usize {
        self.width
    }
    pub fn height(&self) -> usize {
        self.height
    }
    pub fn stride(&self) -> usize {
        self.stride
    }
    /// Row `y`, `width` pixels.
    #[inline]
    pub fn row(&self, y: usize) -> &'a [u8] {
        let s = y * self.stride;
        &self.data[s..s + self.width]
    }
    pub fn to_image(&self) -> GrayImage {
        let mut data = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            data.extend_from_slice(self.row(y));
        }
        GrayImage {
            width: self.width,
            height: self.height,
            data,
        }
    }
}

impl<'a> From<&'a GrayImage> for GrayView<'a> {
    fn from(img: &'a GrayImage) -> Self {
        img.view()
    }
}
