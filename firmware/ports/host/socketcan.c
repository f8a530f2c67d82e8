/* SPDX-License-Identifier: Apache-2.0 */
/* Linux SocketCAN implementation of the CAN port (see socketcan.h). */
#define _GNU_SOURCE
#include "socketcan.h"

#include <errno.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

static void count(uint32_t *c, uint32_t n)
{
    *c = (*c > UINT32_MAX - n) ? UINT32_MAX : *c + n;
}

void sp_socketcan_close(sp_socketcan_t *p)
{
    if (p == NULL) {
        return;
    }
    if (p->fd >= 0) {
        (void)close(p->fd);
    }
    p->fd = -1;
}

static sp_status_t fail(sp_socketcan_t *p, const char *what, const char *ifname)
{
    (void)snprintf(p->error, sizeof p->error, "%s %s: %s", what, ifname, strerror(errno));
    sp_socketcan_close(p);
    return SP_E_IO;
}

/* The socket's options: CAN FD frames, the nflt filters flt, error
 * frames, overflow counts and a large receive buffer. */
static sp_status_t set_options(sp_socketcan_t *p, int fd, const struct can_filter *flt, uint32_t nflt)
{
    int on = 1;
    if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) < 0) {
        return fail(p, "CAN_RAW_FD_FRAMES", "");
    }
    if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, nflt ? (const void *)flt : NULL,
                   (socklen_t)(nflt * sizeof flt[0])) < 0) {
        return fail(p, "CAN_RAW_FILTER", "");
    }
    can_err_mask_t errmask = CAN_ERR_MASK;
    if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &errmask, sizeof errmask) < 0) {
        return fail(p, "CAN_RAW_ERR_FILTER", "");
    }
    if (setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) < 0) {
        return fail(p, "SO_RXQ_OVFL", "");
    }
    /* Room for about a second of the three buses' traffic, so that a
     * scheduling gap of a non-real-time host (user-mode Linux: tens of ms
     * while other processes start) does not drop frames; best effort, the
     * kernel caps it at net.core.rmem_max (SO_RCVBUFFORCE needs
     * CAP_NET_ADMIN). Overflows are still counted (SO_RXQ_OVFL). */
    int rcvbuf = 4 << 20;
    if (setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &rcvbuf, sizeof rcvbuf) < 0) {
        (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    }
    return SP_OK;
}

sp_status_t sp_socketcan_open(sp_socketcan_t *p, const sp_socketcan_bus_cfg_t cfg[SP_CAN_BUSES])
{
    if (p == NULL || cfg == NULL) {
        return SP_E_ARG;
    }
    memset(p, 0, sizeof *p);
    p->fd = -1;
    struct can_filter flt[SP_CAN_BUSES * SP_SOCKETCAN_MAX_FILTERS];
    uint32_t nflt = 0;
    for (uint32_t b = 0; b < SP_CAN_BUSES; b++) {
        const sp_socketcan_bus_cfg_t *c = &cfg[b];
        if (c->ifname != NULL &&
            (c->n_rx_ids > SP_SOCKETCAN_MAX_FILTERS || strlen(c->ifname) >= IFNAMSIZ || c->ifname[0] == '\0')) {
            (void)snprintf(p->error, sizeof p->error, "bad configuration of bus %u", (unsigned)b);
            return SP_E_ARG;
        }
    }
    int fd = socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
    if (fd < 0) {
        return fail(p, "socket(PF_CAN)", "");
    }
    p->fd = fd;
    for (uint32_t b = 0; b < SP_CAN_BUSES; b++) {
        const sp_socketcan_bus_cfg_t *c = &cfg[b];
        if (c->ifname == NULL) {
            continue;
        }
        struct ifreq ifr;
        memset(&ifr, 0, sizeof ifr);
        memcpy(ifr.ifr_name, c->ifname, strlen(c->ifname));
        if (ioctl(fd, SIOCGIFINDEX, &ifr) < 0) {
            return fail(p, "no interface", c->ifname);
        }
        int ifindex = ifr.ifr_ifindex; /* the next ioctl reuses the union */
        if (ioctl(fd, SIOCGIFMTU, &ifr) < 0 || ifr.ifr_mtu != (int)CANFD_MTU) {
            errno = EPROTONOSUPPORT;
            return fail(p, "not a CAN FD interface (mtu 72 needed):", c->ifname);
        }
        for (uint32_t o = 0; o < b; o++) {
            if (p->ifindex[o] == ifindex) {
                errno = EINVAL;
                return fail(p, "two buses on one interface:", c->ifname);
            }
        }
        p->ifindex[b] = ifindex;
        p->n_rx_ids[b] = c->n_rx_ids;
        for (uint32_t i = 0; i < c->n_rx_ids; i++) {
            p->rx_ids[b][i] = c->rx_ids[i] & CAN_SFF_MASK;
            flt[nflt].can_id = c->rx_ids[i] & CAN_SFF_MASK;
            flt[nflt].can_mask = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG;
            nflt++;
        }
    }
    if (set_options(p, fd, flt, nflt) != SP_OK) {
        return SP_E_IO;
    }
    /* ifindex 0: every CAN interface; frames of interfaces that are not ours
     * are dropped in sc_receive, frames sent name their interface. */
    struct sockaddr_can addr;
    memset(&addr, 0, sizeof addr);
    addr.can_family = AF_CAN;
    addr.can_ifindex = 0;
    if (bind(fd, (struct sockaddr *)&addr, sizeof addr) < 0) {
        return fail(p, "bind to", "all CAN interfaces");
    }
    return SP_OK;
}

int sp_socketcan_fd(const sp_socketcan_t *p)
{
    return p == NULL ? -1 : p->fd;
}

static sp_status_t sc_send(void *ctx, const sp_can_frame_t *frames, uint32_t n, uint32_t *sent)
{
    sp_socketcan_t *p = ctx;
    if (p == NULL || sent == NULL || (frames == NULL && n > 0)) {
        return SP_E_ARG;
    }
    *sent = 0;
    sp_status_t result = SP_OK;
    /* One sendmmsg for all buses, frames in their order, each addressed to its interface. */
    for (uint32_t i0 = 0; i0 < n; i0 += SP_SOCKETCAN_BATCH) {
        struct canfd_frame cf[SP_SOCKETCAN_BATCH];
        struct iovec iov[SP_SOCKETCAN_BATCH];
        struct mmsghdr msg[SP_SOCKETCAN_BATCH];
        struct sockaddr_can addr[SP_SOCKETCAN_BATCH];
        uint8_t bus[SP_SOCKETCAN_BATCH];
        uint32_t k = 0;
        for (uint32_t i = i0; i < n && i < i0 + SP_SOCKETCAN_BATCH; i++) {
            const sp_can_frame_t *f = &frames[i];
            if (f->bus >= SP_CAN_BUSES || p->fd < 0 || p->ifindex[f->bus] == 0 || f->len > SP_CAN_MAX_DATA ||
                f->id > CAN_SFF_MASK || (!(f->flags & SP_CAN_FLAG_FD) && f->len > CAN_MAX_DLEN)) {
                result = SP_E_ARG;
                continue;
            }
            memset(&cf[k], 0, sizeof cf[k]);
            cf[k].can_id = f->id;
            cf[k].len = f->len;
            cf[k].flags = (f->flags & SP_CAN_FLAG_BRS) ? CANFD_BRS : 0;
            memcpy(cf[k].data, f->data, f->len);
            iov[k].iov_base = &cf[k];
            iov[k].iov_len = (f->flags & SP_CAN_FLAG_FD) ? CANFD_MTU : CAN_MTU;
            memset(&addr[k], 0, sizeof addr[k]);
            addr[k].can_family = AF_CAN;
            addr[k].can_ifindex = p->ifindex[f->bus];
            memset(&msg[k], 0, sizeof msg[k]);
            msg[k].msg_hdr.msg_name = &addr[k];
            msg[k].msg_hdr.msg_namelen = sizeof addr[k];
            msg[k].msg_hdr.msg_iov = &iov[k];
            msg[k].msg_hdr.msg_iovlen = 1;
            bus[k] = f->bus;
            k++;
        }
        if (k == 0) {
            continue;
        }
        int r = sendmmsg(p->fd, msg, (unsigned)k, MSG_DONTWAIT);
        uint32_t ok = r > 0 ? (uint32_t)r : 0u;
        for (uint32_t j = 0; j < k; j++) {
            count(j < ok ? &p->st[bus[j]].tx_frames : &p->st[bus[j]].tx_dropped, 1u);
        }
        *sent += ok;
        if (ok < k) {
            if (r < 0 && errno != EAGAIN && errno != ENOBUFS) {
                (void)snprintf(p->error, sizeof p->error, "send: %s", strerror(errno));
                result = SP_E_IO;
            } else if (result == SP_OK) {
                result = SP_E_BUSY;
            }
            break; /* keep the order: nothing after a frame that did not go */
        }
    }
    return result;
}

static void handle_error_frame(sp_socketcan_t *p, uint8_t b, const struct canfd_frame *cf)
{
    count(&p->st[b].error_frames, 1);
    if (cf->can_id & CAN_ERR_BUSOFF) {
        p->st[b].bus_off = 1;
    }
    if (cf->can_id & CAN_ERR_RESTARTED) {
        p->st[b].bus_off = 0;
    }
    if ((cf->can_id & CAN_ERR_CRTL) && cf->len > 1) {
        uint8_t c = cf->data[1];
        p->st[b].error_passive = (c & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) ? 1u : 0u;
        if (c & (CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW)) {
            count(&p->st[b].rx_overruns, 1);
        }
    }
}

static int bus_of(const sp_socketcan_t *p, int ifindex)
{
    for (int b = 0; b < (int)SP_CAN_BUSES; b++) {
        if (p->ifindex[b] != 0 && p->ifindex[b] == ifindex) {
            return b;
        }
    }
    return -1;
}

static int wanted(const sp_socketcan_t *p, int b, uint32_t id)
{
    for (uint32_t i = 0; i < p->n_rx_ids[b]; i++) {
        if (p->rx_ids[b][i] == id) {
            return 1;
        }
    }
    return 0;
}

static sp_status_t sc_receive(void *ctx, sp_can_frame_t *frames, uint32_t max, uint32_t *got)
{
    sp_socketcan_t *p = ctx;
    if (p == NULL || got == NULL || (frames == NULL && max > 0)) {
        return SP_E_ARG;
    }
    *got = 0;
    if (p->fd < 0 || max == 0) {
        return SP_OK;
    }
    struct canfd_frame cf[SP_SOCKETCAN_BATCH];
    struct iovec iov[SP_SOCKETCAN_BATCH];
    struct mmsghdr msg[SP_SOCKETCAN_BATCH];
    struct sockaddr_can addr[SP_SOCKETCAN_BATCH];
    char ctrl[SP_SOCKETCAN_BATCH][CMSG_SPACE(sizeof(uint32_t))];
    uint32_t want = max > SP_SOCKETCAN_BATCH ? SP_SOCKETCAN_BATCH : max;
    for (uint32_t k = 0; k < want; k++) {
        iov[k].iov_base = &cf[k];
        iov[k].iov_len = sizeof cf[k];
        memset(&msg[k], 0, sizeof msg[k]);
        msg[k].msg_hdr.msg_name = &addr[k];
        msg[k].msg_hdr.msg_namelen = sizeof addr[k];
        msg[k].msg_hdr.msg_iov = &iov[k];
        msg[k].msg_hdr.msg_iovlen = 1;
        msg[k].msg_hdr.msg_control = ctrl[k];
        msg[k].msg_hdr.msg_controllen = sizeof ctrl[k];
    }
    int r = recvmmsg(p->fd, msg, (unsigned)want, MSG_DONTWAIT, NULL);
    if (r < 0) {
        if (errno != EAGAIN && errno != EWOULDBLOCK) {
            (void)snprintf(p->error, sizeof p->error, "receive: %s", strerror(errno));
            return SP_E_IO;
        }
        return SP_OK;
    }
    for (uint32_t k = 0; k < (uint32_t)r; k++) {
        int b = bus_of(p, addr[k].can_ifindex);
        if (b < 0) {
            continue; /* another CAN interface of this machine */
        }
        for (struct cmsghdr *c = CMSG_FIRSTHDR(&msg[k].msg_hdr); c != NULL; c = CMSG_NXTHDR(&msg[k].msg_hdr, c)) {
            if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
                uint32_t drops;
                memcpy(&drops, CMSG_DATA(c), sizeof drops);
                /* the kernel counts per socket, a uint32 that wraps: the difference
                 * modulo 2^32; charged to the bus of the next frame */
                count(&p->st[b].rx_overruns, drops - p->last_drops);
                p->last_drops = drops;
            }
        }
        const struct canfd_frame *f = &cf[k];
        if (f->can_id & CAN_ERR_FLAG) {
            handle_error_frame(p, (uint8_t)b, f);
            continue;
        }
        count(&p->st[b].rx_frames, 1);
        if ((f->can_id & (CAN_EFF_FLAG | CAN_RTR_FLAG)) || !wanted(p, b, f->can_id & CAN_SFF_MASK)) {
            continue; /* not for us on this bus (the kernel filter is the union of all buses) */
        }
        sp_can_frame_t *o = &frames[*got];
        memset(o, 0, sizeof *o);
        o->id = f->can_id & CAN_SFF_MASK;
        o->bus = (uint8_t)b;
        o->len = f->len > SP_CAN_MAX_DATA ? (uint8_t)SP_CAN_MAX_DATA : f->len;
        o->flags = (uint8_t)((msg[k].msg_len == CANFD_MTU ? SP_CAN_FLAG_FD : 0u) |
                             ((f->flags & CANFD_BRS) ? SP_CAN_FLAG_BRS : 0u));
        memcpy(o->data, f->data, o->len);
        (*got)++;
    }
    return SP_OK;
}

static sp_status_t sc_bus_status(void *ctx, uint8_t bus, sp_bus_status_t *status)
{
    sp_socketcan_t *p = ctx;
    if (p == NULL || status == NULL || bus >= SP_CAN_BUSES) {
        return SP_E_ARG;
    }
    *status = p->st[bus];
    return SP_OK;
}

sp_can_port_t sp_socketcan_port(sp_socketcan_t *p)
{
    sp_can_port_t port = {p, sc_send, sc_receive, sc_bus_status};
    return port;
}
