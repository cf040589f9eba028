//! The one binding layout of the shading kernels (`forward.comp`, `grad.comp`, `tangent.comp`):
//! a slot holds the same buffer in every kernel. GLSL twin: `shaders/inc/shade_bindings.glsl`,
//! which declares every slot (`SA_BIND_*`) and gives each kernel the slots its role uses; the
//! tests below check that its numbers are this table's and that no shading kernel numbers a
//! binding itself. Every shading dispatch takes its buffers from [`shade_buffers`] (through
//! `record_passes`).
use crate::vulkan::{Buffer, Texel};
use crate::GpuScene;

/// A slot of the shading layout (its binding is its place in [`SLOTS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Slot {
    Views,
    Offsets,
    List,
    Stats,
    Coverage,
    PairStore,
    Image,
    Carry,
    Dl,
    Partials,
    Seeds,
    Tangents,
    Records,
    PixelRecords,
    ListTex,
    StoreTex,
}

/// Every slot in binding order, with its GLSL name (`SA_BIND_<name>`). The storage buffers come
/// first, then [`TEXELS`] texel buffers (the Vulkan layer's convention).
pub(crate) const SLOTS: [(Slot, &str); 16] = [
    (Slot::Views, "VIEWS"),
    (Slot::Offsets, "OFFSETS"),
    (Slot::List, "LIST"),
    (Slot::Stats, "STATS"),
    (Slot::Coverage, "COVERAGE"),
    (Slot::PairStore, "PAIR_STORE"),
    (Slot::Image, "IMAGE"),
    (Slot::Carry, "CARRY"),
    (Slot::Dl, "DL"),
    (Slot::Partials, "PARTIALS"),
    (Slot::Seeds, "SEEDS"),
    (Slot::Tangents, "TANGENTS"),
    (Slot::Records, "RECORDS"),
    (Slot::PixelRecords, "PIXEL_RECORDS"),
    (Slot::ListTex, "LIST_TEX"),
    (Slot::StoreTex, "STORE_TEX"),
];

/// The texel buffers after the storage buffers: all read (`uniform samplerBuffer`).
pub(crate) const TEXELS: [Texel; 4] = [Texel::Read; 4];

/// Storage-buffer slots (the first ones).
pub(crate) const STORAGE: u32 = (SLOTS.len() - TEXELS.len()) as u32;

/// The three shading kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kernel {
    Forward,
    Backward,
    Tangent,
}

impl Slot {
    /// The kernel whose own slot this is; `None` for a slot every kernel uses (coverage and the
    /// pair store: the forward writes them, the others read them).
    pub(crate) fn owner(self) -> Option<Kernel> {
        match self {
            Slot::Image | Slot::Carry => Some(Kernel::Forward),
            Slot::Dl | Slot::Partials | Slot::StoreTex => Some(Kernel::Backward),
            Slot::Seeds | Slot::Tangents => Some(Kernel::Tangent),
            _ => None,
        }
    }
}

/// What a shading dispatch does, with the buffers of its kernel's own slots.
#[derive(Clone, Copy)]
pub(crate) enum Role<'a> {
    /// Writes the image, the coverage, the carry and the pair store.
    Forward,
    /// Reads dE/dL (and the pair store), writes partial gradients per tile-list entry.
    Backward { dl: &'a Buffer, partials: &'a Buffer },
    /// Reads the per-scratch tangent seeds, adds per-pixel tangents.
    Tangent { seeds: &'a Buffer, tangents: &'a Buffer },
}

impl Role<'_> {
    fn kernel(&self) -> Kernel {
        match self {
            Role::Forward => Kernel::Forward,
            Role::Backward { .. } => Kernel::Backward,
            Role::Tangent { .. } => Kernel::Tangent,
        }
    }
}

/// The buffers of one shading dispatch of `gs`, in binding order: the scene's buffers in the
/// shared slots, the role's in its own, and the scene's placeholder (`GpuScene::unbound`) in
/// the other kernels' slots, which this kernel does not declare.
pub(crate) fn shade_buffers<'a>(gs: &'a GpuScene, role: Role<'a>) -> [&'a Buffer; SLOTS.len()] {
    SLOTS.map(|(slot, _)| {
        if slot.owner().is_some_and(|k| k != role.kernel()) {
            return &gs.shading.unbound;
        }
        match (slot, role) {
            (Slot::Views, _) => &gs.inputs.views,
            (Slot::Offsets, _) => &gs.bin.hist,
            (Slot::List | Slot::ListTex, _) => &gs.bin.list,
            (Slot::Stats, _) => &gs.stats,
            (Slot::Coverage, _) => &gs.shading.cov_raw,
            (Slot::PairStore | Slot::StoreTex, _) => &gs.shading.pair_store,
            (Slot::Records, _) => &gs.inputs.records,
            (Slot::PixelRecords, _) => &gs.inputs.pixel_records,
            (Slot::Image, _) => &gs.shading.image,
            (Slot::Carry, _) => &gs.shading.carry,
            (Slot::Dl, Role::Backward { dl, .. }) => dl,
            (Slot::Partials, Role::Backward { partials, .. }) => partials,
            (Slot::Seeds, Role::Tangent { seeds, .. }) => seeds,
            (Slot::Tangents, Role::Tangent { tangents, .. }) => tangents,
            (Slot::Dl | Slot::Partials | Slot::Seeds | Slot::Tangents, _) => unreachable!("owned by another kernel"),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = include_str!("../../../shaders/inc/shade_bindings.glsl");

    /// `#define SA_BIND_<NAME> <n>` lines of the GLSL header, in order.
    fn header_slots() -> Vec<(String, usize)> {
        HEADER
            .lines()
            .filter_map(|l| {
                let rest = l.trim().strip_prefix("#define SA_BIND_")?;
                let mut it = rest.split_whitespace();
                let name = it.next()?.to_string();
                let n = it.next()?.parse().ok()?;
                Some((name, n))
            })
            .collect()
    }

    #[test]
    fn the_glsl_header_numbers_the_slots_as_the_table_does() {
        let header = header_slots();
        let table: Vec<(String, usize)> = SLOTS.iter().enumerate().map(|(i, (_, n))| (n.to_string(), i)).collect();
        assert_eq!(header, table, "shaders/inc/shade_bindings.glsl against SLOTS");
        let count = HEADER
            .lines()
            .find_map(|l| l.trim().strip_prefix("#define SA_SHADE_SLOTS "))
            .and_then(|n| n.split_whitespace().next()?.parse::<usize>().ok());
        assert_eq!(count, Some(SLOTS.len()), "SA_SHADE_SLOTS");
        // Texel slots are declared as texel buffers, storage slots as storage buffers.
        for (i, (_, name)) in SLOTS.iter().enumerate() {
            let texel = i >= STORAGE as usize;
            let decl = format!("binding = SA_BIND_{name})");
            for l in HEADER.lines().filter(|l| l.contains(&decl)) {
                assert_eq!(l.contains("samplerBuffer"), texel, "slot {name}: {l}");
            }
        }
    }

    /// The slots the header declares for `kernel`: those outside its role sections, and those
    /// in the section of `kernel` (`#if defined(SA_SHADE_FORWARD)`, `#elif defined(SA_SHADE_BACKWARD)`,
    /// `#else`: the tangent).
    fn declared(kernel: Kernel) -> Vec<&'static str> {
        let mut section: Option<Kernel> = None;
        let mut out = Vec::new();
        for l in HEADER.lines().map(str::trim) {
            match l {
                "#if defined(SA_SHADE_FORWARD)" => section = Some(Kernel::Forward),
                "#elif defined(SA_SHADE_BACKWARD)" => section = Some(Kernel::Backward),
                "#else" if section.is_some() => section = Some(Kernel::Tangent),
                "#endif" => section = None,
                _ => {}
            }
            if section.is_some_and(|k| k != kernel) {
                continue;
            }
            for (_, name) in SLOTS {
                if l.starts_with("layout(") && l.contains(&format!("binding = SA_BIND_{name})")) {
                    out.push(name);
                }
            }
        }
        out
    }

    #[test]
    fn each_kernel_declares_the_shared_slots_and_its_own() {
        for kernel in [Kernel::Forward, Kernel::Backward, Kernel::Tangent] {
            let decl = declared(kernel);
            for (slot, name) in SLOTS {
                let used = match slot.owner() {
                    None => true,
                    Some(k) => k == kernel,
                };
                // The tangent kernel reads neither the pair store nor its texel view: a shared
                // slot a kernel may leave out, never another kernel's slot it may declare.
                let optional = kernel == Kernel::Tangent && slot == Slot::PairStore;
                assert!(
                    decl.contains(&name) == used || optional,
                    "{kernel:?}: slot {name} declared {} but used {used} (Slot::owner)",
                    decl.contains(&name)
                );
            }
        }
    }

    #[test]
    fn no_shading_kernel_numbers_a_binding_itself() {
        let sources = [
            ("forward.comp", include_str!("../../../shaders/forward.comp")),
            ("grad.comp", include_str!("../../../shaders/grad.comp")),
            ("tangent.comp", include_str!("../../../shaders/tangent.comp")),
            (
                "inc/tile_loop.glsl",
                include_str!("../../../shaders/inc/tile_loop.glsl"),
            ),
            (
                "inc/tile_queue.glsl",
                include_str!("../../../shaders/inc/tile_queue.glsl"),
            ),
            (
                "inc/scratch_records.glsl",
                include_str!("../../../shaders/inc/scratch_records.glsl"),
            ),
        ];
        for (file, src) in sources {
            for (n, line) in src.lines().enumerate() {
                let code = line.split("//").next().unwrap_or("");
                assert!(
                    !(code.contains("layout(") && code.contains("binding")),
                    "{file}:{}: declares a binding; declare it in inc/shade_bindings.glsl and bindings.rs",
                    n + 1
                );
            }
        }
        for (file, src, role) in [
            ("forward.comp", sources[0].1, "SA_SHADE_FORWARD"),
            ("grad.comp", sources[1].1, "SA_SHADE_BACKWARD"),
            ("tangent.comp", sources[2].1, "SA_SHADE_TANGENT"),
        ] {
            assert!(src.contains(&format!("#define {role}\n")), "{file} defines {role}");
        }
    }
}
