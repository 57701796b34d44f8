// The signed-in API key, kept in this browser's localStorage.

const STORAGE_KEY = "rigforge.apiKey";

export function getKey(): string | null {
  return localStorage.getItem(STORAGE_KEY);
}

export function setKey(secret: string): void {
  localStorage.setItem(STORAGE_KEY, secret.trim());
}

export function clearKey(): void {
  localStorage.removeItem(STORAGE_KEY);
}

/** `url` with `?key=` appended: for EventSource and download links, which cannot send headers. */
export function withKey(url: string): string {
  const key = getKey();
  if (!key) return url;
  const u = new URL(url, location.href);
  u.searchParams.set("key", key);
  return u.pathname + u.search;
}
