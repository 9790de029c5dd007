//! GPU timestamps around passes.

use ash::vk;

use super::context::GpuContext;
use super::owned::{Owned, OwnedResult};
use crate::error::{Error, Result, VkContext};

/// A pool of `count` timestamp queries. `None`-like when the queue has no timestamps.
pub struct Timestamps {
    pool: Owned<vk::QueryPool>,
    count: u32,
    period_ns: f64,
    valid_mask: u64,
}

impl Timestamps {
    /// `None` when the queue does not support timestamps.
    pub fn new(ctx: &GpuContext, count: u32) -> Result<Option<Self>> {
        let bits = ctx.timestamp_valid_bits;
        if bits == 0 || ctx.properties.limits.timestamp_period <= 0.0 {
            return Ok(None);
        }
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(count);
        // SAFETY: valid device.
        let pool = unsafe { ctx.device.create_query_pool(&info, None) }
            .vk("vkCreateQueryPool")
            .owned(ctx)?;
        ctx.name(*pool, "timestamps");
        Ok(Some(Timestamps {
            pool,
            count,
            period_ns: ctx.properties.limits.timestamp_period as f64,
            valid_mask: if bits >= 64 {
                u64::MAX
            } else {
                (1u64 << bits) - 1
            },
        }))
    }

    /// Records the reset of all queries (before the first write of a frame).
    pub fn reset(&self, d: &ash::Device, cmd: vk::CommandBuffer) {
        // SAFETY: cmd is recording outside a render pass instance.
        unsafe { d.cmd_reset_query_pool(cmd, *self.pool, 0, self.count) };
    }

    /// Records a timestamp after all previous work reached `stage`.
    pub fn write(
        &self,
        d: &ash::Device,
        cmd: vk::CommandBuffer,
        stage: vk::PipelineStageFlags2,
        i: u32,
    ) {
        // SAFETY: query i < count was reset in this command buffer.
        unsafe { d.cmd_write_timestamp2(cmd, stage, *self.pool, i) };
    }

    /// Milliseconds between consecutive timestamps (count − 1 values) once the submission
    /// that wrote them completed; `None` while any is not available yet (NOT_READY is the
    /// legal answer then, not an error). Never blocks: callers read after their fence.
    pub fn read_ms(&self, ctx: &GpuContext) -> Result<Option<Vec<f64>>> {
        let mut raw = vec![0u64; self.count as usize];
        // SAFETY: valid pool; without WAIT the call returns at once.
        let r = unsafe {
            ctx.device.get_query_pool_results(
                *self.pool,
                0,
                &mut raw,
                vk::QueryResultFlags::TYPE_64,
            )
        };
        match r {
            Ok(()) => {}
            Err(vk::Result::NOT_READY) => return Ok(None),
            Err(result) => {
                return Err(Error::VkCall {
                    call: "vkGetQueryPoolResults",
                    result,
                })
            }
        }
        Ok(Some(
            raw.windows(2)
                .map(|w| {
                    let ticks = (w[1] & self.valid_mask).wrapping_sub(w[0] & self.valid_mask)
                        & self.valid_mask;
                    ticks as f64 * self.period_ns / 1e6
                })
                .collect(),
        ))
    }
}

/// The median of frame times; `None` for none. An even count gives the mean of the middle two.
pub fn median(values: &[f64]) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}
