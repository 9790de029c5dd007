//! The throughput roof of known GPUs: nominal bilinear texture rate and memory bandwidth, so a
//! measured throughput can be put as a fraction of what the device could do. Values are the
//! vendors' boost-clock specifications (texture units × boost clock; memory bandwidth), not
//! measurements; `--peak-gtexels` and `--peak-gbps` override or supply them.

/// A device's nominal peaks.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Peak {
    /// Bilinear texels per second, in billions.
    pub gtexels: Option<f64>,
    /// Memory bandwidth in GB/s.
    pub gbps: Option<f64>,
    /// Where the numbers come from: the table entry, "command line", or "unknown".
    pub source: String,
}

/// (substring of the Vulkan device name, GTexel/s, GB/s). More specific names come first.
const TABLE: &[(&str, f64, f64)] = &[
    ("H200", 1045.0, 4800.0),
    ("H100 PCIe", 800.0, 2000.0),
    ("H100 NVL", 1045.0, 3900.0),
    ("H100", 1045.0, 3350.0),
    ("A100-SXM4-80GB", 609.0, 2039.0),
    ("A100", 609.0, 1555.0),
    ("L40S", 1431.0, 864.0),
    ("A10G", 438.0, 600.0),
    ("A10", 488.0, 600.0),
    ("T4", 255.0, 320.0),
    ("RTX 4090", 1290.0, 1008.0),
    ("RTX 4080", 762.0, 717.0),
    ("RTX 4070", 455.0, 504.0),
    ("RTX 3090", 556.0, 936.0),
    ("RTX 3080", 465.0, 760.0),
    ("RTX 3070", 318.0, 448.0),
    ("RTX 2080 Ti", 420.0, 616.0),
    ("RTX A6000", 625.0, 768.0),
    ("Radeon RX 7900 XTX", 960.0, 960.0),
];

/// The peaks of `device` from the table, with command-line overrides applied.
pub fn peak_of(device: &str, gtexels: Option<f64>, gbps: Option<f64>) -> Peak {
    let known = TABLE.iter().find(|(name, _, _)| device.contains(name));
    let source = match (known, gtexels.is_some() || gbps.is_some()) {
        (_, true) => "command line".to_string(),
        (Some((name, _, _)), false) => format!("nominal specification of the {name}"),
        (None, false) => "unknown".to_string(),
    };
    Peak {
        gtexels: gtexels.or(known.map(|k| k.1)),
        gbps: gbps.or(known.map(|k| k.2)),
        source,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specific_names_win_and_overrides_apply() {
        let pcie = peak_of("NVIDIA H100 PCIe", None, None);
        assert_eq!((pcie.gtexels, pcie.gbps), (Some(800.0), Some(2000.0)));
        assert_eq!(
            peak_of("NVIDIA H100 80GB HBM3", None, None).gbps,
            Some(3350.0)
        );
        assert_eq!(peak_of("NVIDIA H200", None, None).gbps, Some(4800.0));
        let cpu = peak_of("llvmpipe (LLVM 15.0.6, 256 bits)", None, None);
        assert_eq!(
            (cpu.gtexels, cpu.gbps, cpu.source.as_str()),
            (None, None, "unknown")
        );
        let o = peak_of("llvmpipe", Some(2.0), None);
        assert_eq!((o.gtexels, o.source.as_str()), (Some(2.0), "command line"));
        let mixed = peak_of("NVIDIA GeForce RTX 4090", None, Some(900.0));
        assert_eq!((mixed.gtexels, mixed.gbps), (Some(1290.0), Some(900.0)));
    }
}
