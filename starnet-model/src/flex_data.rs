//! Flex tensors as plain row-major `f32` values and back: what the fused operations (the
//! StarNet block, the heads, the loss) and the replica sums read and write.

use burn::backend::flex::FlexTensor;
use burn::tensor::TensorData;
use std::borrow::Cow;

/// A contiguous f32 view of a flex tensor, copying only if it is strided.
pub(crate) fn values(t: &FlexTensor) -> Cow<'_, [f32]> {
    match t.as_slice::<f32>() {
        Some(s) => Cow::Borrowed(s),
        None => Cow::Owned(t.to_contiguous().into_data().iter::<f32>().collect()),
    }
}

/// A flex tensor of `shape` holding `values` (row-major).
pub(crate) fn flex(values: Vec<f32>, shape: Vec<usize>) -> FlexTensor {
    FlexTensor::from_data(TensorData::new(values, shape))
}
