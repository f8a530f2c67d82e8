/* SPDX-License-Identifier: Apache-2.0 */
/*
 * sp_abi.h - the memory layout of the core's structs that the host tools
 * mirror in Python (tools/stewart/core.py, ctypes): for each struct its size,
 * and for each member its offset and size, as this compiler lays them out.
 * The tools compare their mirrors with this table when they load the shared
 * library and refuse to run on a mismatch.
 *
 * Built into the shared library (sp_core_shared) only, never into the
 * firmware image.
 */
#ifndef SP_ABI_H
#define SP_ABI_H

#include <stdint.h>

/** One member of a mirrored struct. */
typedef struct {
    const char *type;     /**< C type name, e.g. "sp_pose_t" */
    uint32_t type_size;   /**< sizeof the type */
    const char *member;   /**< member name, e.g. "rpy" */
    uint32_t offset;      /**< offsetof(type, member) */
    uint32_t member_size; /**< sizeof the member */
} sp_abi_member_t;

/**
 * The table: every member of every mirrored struct, in declaration order.
 * Sets *count to its number of rows and *row_size to sizeof(sp_abi_member_t)
 * (so that a reader can check its own mirror of this row first).
 */
const sp_abi_member_t *sp_abi_members(uint32_t *count, uint32_t *row_size);

#endif /* SP_ABI_H */
