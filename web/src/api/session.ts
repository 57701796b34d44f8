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
