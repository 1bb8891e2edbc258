// The invocation's place in its workgroup and subgroup, for the reductions'
// subgroup trees (composed only for a device with subgroup operations).
// Their entry points are one-dimensional: naga refuses subgroup_id and
// subgroup_invocation_id with a multi-dimensional workgroup.
struct Lanes {
    @builtin(local_invocation_index) li: u32,
    @builtin(subgroup_invocation_id) lane: u32,
    @builtin(subgroup_size) size: u32,
    @builtin(subgroup_id) id: u32,
    @builtin(num_subgroups) count: u32,
}
