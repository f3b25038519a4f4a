/*
 * The Unix socket the hosted programs' hub clients (can_hub_client.c, rs485_hub_client.c) open to
 * their hub (tools/can_hub.py, tools/rs485_hub.py): one SOCK_SEQPACKET connection.
 */
#ifndef URB_HUB_SOCKET_H
#define URB_HUB_SOCKET_H

/** Connects a SOCK_SEQPACKET socket to the hub listening at `path`; its descriptor, or -1 with
 *  errno set (ENAMETOOLONG for a path longer than a Unix socket address holds, ENOENT or
 *  ECONNREFUSED when no hub listens there). */
int urb_hub_socket_connect(const char *path);

#endif /* URB_HUB_SOCKET_H */
