//! The fused StarNet block: the block's forward and backward as one operation on raw f32 rows
//! ([`kernel`]), bound into Burn's flex backend and its autodiff graph ([`op`]). One op replaces
//! the dozens of small tensor operations (each an allocation and a pass over memory) that the
//! composed block ([`crate::nn::StarNetBlock`] with `fused = false`) records; the composed block
//! stays the reference and the path on other backends. The whole featurizer (fc0, the blocks,
//! the readout) runs the same way as one operation ([`stack`], [`stack_op`]). Both work on the
//! real points only, packed end to end ([`packed`]): a padded slot costs nothing. The
//! projector's Linear and ReLU and the heads after it are a third ([`head`], [`head_op`]).

mod gemm;
pub mod head;
pub mod head_op;
pub mod kernel;
mod moments;
pub mod packed;
mod rows;
pub mod stack;

pub use gemm::{Mat, Op, Write, matmul, matmul_new, matmul_tn};
pub mod op;
pub mod stack_op;
